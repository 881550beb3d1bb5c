// The gRPC listening credentials semmapd serves with: plaintext, server TLS, or mutual TLS.
#pragma once

#include <grpcpp/security/server_credentials.h>

#include <memory>

#include "common/status.h"
#include "server/server_options.h"

namespace semmap {

// Plaintext without options.tls_cert_file; TLS with it (and the key); with
// tls_client_ca_file, clients must present a certificate that CA signed. INVALID_ARGUMENT
// naming the flag for a file that cannot be read or is not PEM.
StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(
    const ServerOptions& options);

}  // namespace semmap

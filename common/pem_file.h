// Reads a PEM file (certificate, private key, CA bundle) named on a command line, with errors
// that name the flag: TLS set-up mistakes are the commonest start-up failure.
#pragma once

#include <string>
#include <string_view>

#include "common/status.h"

namespace semmap {

// The file's text. INVALID_ARGUMENT naming `flag` when it cannot be read, is empty, larger
// than 1 MiB or holds no "-----BEGIN " block. (The TLS library parses the blocks.)
StatusOr<std::string> ReadPemFile(const std::string& path, std::string_view flag);

}  // namespace semmap

// Everything semmapd can be told, validated once at start and logged.
#pragma once

#include <string>

#include "common/logging.h"
#include "common/status.h"
#include "core/pipeline/ingest_options.h"
#include "core/recognition/object_model.h"
#include "server/service/call_limits.h"

namespace semmap {

// Whether HOST:PORT names this machine only: 127.x, localhost, [::1], unix:.
bool IsLoopbackAddress(const std::string& listen);
// unix:/PATH: a Unix domain socket on this machine (who may connect is the path's permissions).
bool IsUnixSocketAddress(const std::string& listen);
// The PATH of unix:/PATH.
std::string UnixSocketPathOf(const std::string& listen);

struct ServerOptions {
  // Library defaults, except what a long-running server wants: compact keyframe clouds.
  ServerOptions() { ingest.layers.occupancy.keyframe_voxel_m = kServerKeyframeVoxelM; }
  static constexpr double kServerKeyframeVoxelM = 0.02;

  std::string listen = "127.0.0.1:50051";
  std::string data_dir = "./semmap-data";
  LogLevel log_level = LogLevel::kInfo;  // semmapd applies it process-wide (SetLogLevel)
  bool sync_full = true;  // SQLite synchronous=FULL: acknowledged-durable frames survive power loss
  int max_message_mb = 64;
  // TLS (PEM files): server certificate chain and key, both or neither (plaintext); with a
  // client CA, only clients presenting a certificate it signed are served (mutual TLS).
  std::string tls_cert_file;
  std::string tls_key_file;
  std::string tls_client_ca_file;
  // Bearer tokens and their roles (server/auth/token_table.h); empty: every caller served.
  std::string auth_tokens_file;
  // Plaintext is refused on an address other than loopback unless this is set.
  bool allow_insecure = false;
  int shutdown_grace_s = 5;            // time in-flight streams get to finish at shutdown
  size_t storage_queue_capacity = 64;  // write batches waiting for the storage writer
  CallLimits calls;                    // query workers and the limits on costly calls
  IngestOptions ingest;
  // Place-recognition vocabulary of the SLAM back end. Empty: none (loops by pose proximity
  // only). A path that cannot be loaded fails the start unless vocabulary_optional.
  std::string vocabulary_path;
  bool vocabulary_optional = false;
  // The learned VO network MONO sessions run (its JSON sidecar next to it). Empty: none (MONO
  // sessions are refused with FAILED_PRECONDITION). A model that cannot be loaded fails the
  // start unless vo_model_optional: then MONO is refused saying why and the rest serves.
  std::string vo_model_path;
  bool vo_model_optional = false;
  // How object photos are described and objects recognised in keyframes.
  ObjectRecognitionOptions recognition;

  Status Validate() const;
  std::string ToString() const;  // one line per option, for the start-up log
};

}  // namespace semmap

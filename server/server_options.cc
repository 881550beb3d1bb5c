#include "server/server_options.h"

#include <sstream>
#include <string_view>

namespace semmap {

bool IsLoopbackAddress(const std::string& listen) {
  const std::string host = listen.substr(0, listen.rfind(':'));
  return host == "localhost" || host == "[::1]" || host.rfind("127.", 0) == 0 ||
         IsUnixSocketAddress(listen);
}

constexpr std::string_view kUnixScheme = "unix:";

bool IsUnixSocketAddress(const std::string& listen) { return listen.starts_with(kUnixScheme); }

std::string UnixSocketPathOf(const std::string& listen) {
  return listen.substr(kUnixScheme.size());
}

namespace {

// unix:/absolute/path: the path must fit a sockaddr_un (108 bytes with its NUL).
constexpr size_t kMaxUnixPathBytes = 107;

Status ValidateUnixSocketAddress(const std::string& listen) {
  const std::string path = UnixSocketPathOf(listen);
  if (path.empty() || path.front() != '/') {
    return InvalidArgumentError(
        "--listen unix: wants an absolute path, e.g. unix:/run/semmap/semmapd.sock (got '" +
        listen + "')");
  }
  if (path.size() > kMaxUnixPathBytes) {
    return InvalidArgumentError("--listen unix socket path is " + std::to_string(path.size()) +
                                " bytes; Linux allows at most " +
                                std::to_string(kMaxUnixPathBytes));
  }
  if (path.find_first_of(std::string("\0\n", 2)) != std::string::npos) {
    return InvalidArgumentError("--listen unix socket path has a NUL or newline");
  }
  return OkStatus();
}

}  // namespace

Status ServerOptions::Validate() const {
  if (IsUnixSocketAddress(listen)) {
    SEMMAP_RETURN_IF_ERROR(ValidateUnixSocketAddress(listen));
  } else {
    const size_t colon = listen.rfind(':');
    if (listen.empty() || colon == std::string::npos || colon == 0) {
      return InvalidArgumentError("--listen must be HOST:PORT or unix:/PATH (got '" + listen +
                                  "')");
    }
    const std::string port = listen.substr(colon + 1);
    if (port.empty() || port.size() > 5 ||
        port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) > 65535) {
      return InvalidArgumentError("--listen port must be a number in 0..65535 (got '" + port +
                                  "')");
    }
  }
  if (data_dir.empty()) return InvalidArgumentError("--data-dir must not be empty");
  if (tls_cert_file.empty() != tls_key_file.empty()) {
    return InvalidArgumentError("--tls-cert and --tls-key go together (got only " +
                                std::string(tls_cert_file.empty() ? "--tls-key" : "--tls-cert") +
                                ")");
  }
  if (!tls_client_ca_file.empty() && tls_cert_file.empty()) {
    return InvalidArgumentError("--tls-client-ca needs --tls-cert and --tls-key (mutual TLS)");
  }
  if (tls_cert_file.empty() && !allow_insecure && !IsLoopbackAddress(listen)) {
    return FailedPreconditionError(
        "refusing to serve " + listen +
        " in plaintext: anyone who can reach it could read, change and delete every map; give "
        "--tls-cert and --tls-key, or --allow-insecure on a network you trust");
  }
  if (max_message_mb < 1 || max_message_mb > 1024) {
    return InvalidArgumentError("--max-message-mb must be in 1..1024");
  }
  if (shutdown_grace_s < 0 || shutdown_grace_s > 60) {
    return InvalidArgumentError("--shutdown-grace-s must be in 0..60");
  }
  if (storage_queue_capacity < 1 || storage_queue_capacity > 4096) {
    return InvalidArgumentError("storage queue capacity must be in 1..4096");
  }
  SEMMAP_RETURN_IF_ERROR(calls.Validate());
  SEMMAP_RETURN_IF_ERROR(recognition.Validate().WithContext("object recognition"));
  return ingest.Validate();
}

std::string ServerOptions::ToString() const {
  std::ostringstream out;
  out << "listen=" << listen << " data_dir=" << data_dir << " log_level=" << LogLevelName(log_level)
      << " sqlite_synchronous=" << (sync_full ? "FULL" : "NORMAL") << " tls="
      << (tls_cert_file.empty()        ? "off"
          : tls_client_ca_file.empty() ? "on"
                                       : "mutual")
      << " auth=" << (auth_tokens_file.empty() ? "off" : "tokens")
      << " max_message_mb=" << max_message_mb << " shutdown_grace_s=" << shutdown_grace_s
      << " queue_capacity=" << ingest.queue_capacity
      << " max_frame_bytes=" << ingest.max_frame_bytes << " max_streams=" << ingest.max_streams
      << " max_open_maps=" << ingest.max_open_maps << " max_idle_maps=" << ingest.max_idle_maps
      << " stream_idle_timeout_s=" << ingest.idle_timeout_s
      << " max_session_fps=" << ingest.max_frames_per_second << " query_workers=" << calls.workers
      << " query_queue=" << calls.worker_queue
      << " max_pending_exports=" << calls.max_pending_exports
      << " max_registrations_per_minute=" << calls.max_registrations_per_minute
      << " keyframe_min_motion=" << ingest.keyframes.min_motion
      << " keyframe_rotation_weight=" << ingest.keyframes.rotation_weight
      << " keyframe_skip_mapped=" << (ingest.keyframes.skip_mapped_views ? "on" : "off")
      << " vocabulary=" << (vocabulary_path.empty() ? "none" : vocabulary_path)
      << " vo_model=" << (vo_model_path.empty() ? "none" : vo_model_path)
      << " mono_vo=" << (ingest.mono_method == MonoVoMethod::kNet ? "net" : "hybrid")
      << " loop_max_xi=" << ingest.slam.verifier.max_xi
      << " local_ba=" << (ingest.slam.local_ba.enabled ? "on" : "off")
      << " final_ba=" << (ingest.slam.local_ba.final_ba ? "on" : "off") << " point_fusion="
      << (!ingest.slam.point_fusion.enabled            ? "off"
          : ingest.slam.point_fusion.merge_established ? "all"
                                                       : "on")
      << " slam_features_mb=" << (ingest.slam.features_memory_bytes >> 20)
      << " map_layers=" << (ingest.layers.enabled ? "on" : "off")
      << " map_resolution=" << ingest.layers.occupancy.resolution_m
      << " map_max_range=" << ingest.layers.occupancy.max_range_m
      << " map_keyframe_voxel=" << ingest.layers.occupancy.keyframe_voxel_m
      << " cloud_voxel=" << ingest.layers.cloud.leaf_size_m
      << " objects=" << (ingest.objects.enabled ? "on" : "off")
      << " object_max_xi=" << recognition.max_xi
      << " object_min_inliers=" << recognition.min_inliers;
  return out.str();
}

}  // namespace semmap

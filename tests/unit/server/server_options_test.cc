#include "server/server_options.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(ServerOptionsTest, DefaultsAreValid) { EXPECT_TRUE(ServerOptions{}.Validate().ok()); }

TEST(ServerOptionsTest, ListenAddressIsChecked) {
  ServerOptions o;
  for (const char* bad : {"", "nohost", ":50051", "127.0.0.1:", "127.0.0.1:99999", "h:12a"}) {
    o.listen = bad;
    EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument) << bad;
  }
  for (const char* good : {"127.0.0.1:0", "[::1]:65535", "localhost:1"}) {
    o.listen = good;
    EXPECT_TRUE(o.Validate().ok()) << good;
  }
}

TEST(ServerOptionsTest, UnixSocketPathsAreAbsoluteAndFitASocketAddress) {
  ServerOptions o;
  o.listen = "unix:/run/semmap/semmapd.sock";
  EXPECT_TRUE(o.Validate().ok());  // loopback: no TLS asked for
  EXPECT_TRUE(IsUnixSocketAddress(o.listen));
  for (const std::string& bad : {std::string("unix:"), std::string("unix:relative.sock"),
                                 "unix:/" + std::string(107, 'a'), std::string("unix:/tmp/a\nb")}) {
    o.listen = bad;
    EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument) << bad;
  }
  o.listen = "unix:/" + std::string(106, 'a');  // 107 bytes with the slash: the most that fits
  EXPECT_TRUE(o.Validate().ok());
}

TEST(ServerOptionsTest, PlaintextOffLoopbackNeedsAllowInsecure) {
  ServerOptions o;
  o.listen = "0.0.0.0:50051";
  const Status refused = o.Validate();
  EXPECT_EQ(refused.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.message().find("--allow-insecure"), std::string::npos) << refused.ToString();
  o.allow_insecure = true;
  EXPECT_TRUE(o.Validate().ok());
  o.allow_insecure = false;
  o.tls_cert_file = "server.pem";  // TLS: fine anywhere (the files are read at start)
  o.tls_key_file = "server.key";
  EXPECT_TRUE(o.Validate().ok());
  o.tls_key_file.clear();
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o.tls_cert_file.clear();
  o.tls_client_ca_file = "ca.pem";
  o.listen = "127.0.0.1:0";
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(IsLoopbackAddress("127.0.0.2:1"));
  EXPECT_TRUE(IsLoopbackAddress("unix:/tmp/semmap.sock"));
  EXPECT_FALSE(IsLoopbackAddress("192.168.1.5:50051"));
  EXPECT_FALSE(IsLoopbackAddress("example.org:50051"));
}

TEST(ServerOptionsTest, LimitsAreChecked) {
  ServerOptions o;
  o.max_message_mb = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = ServerOptions{};
  o.ingest.queue_capacity = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = ServerOptions{};
  o.ingest.keyframes.min_motion = -1;
  EXPECT_FALSE(o.Validate().ok());
  o = ServerOptions{};
  o.storage_queue_capacity = 0;
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace semmap

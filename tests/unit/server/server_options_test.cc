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
  for (const char* good : {"127.0.0.1:0", "0.0.0.0:50051", "[::1]:65535", "localhost:1"}) {
    o.listen = good;
    EXPECT_TRUE(o.Validate().ok()) << good;
  }
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

// semmapd --auth-tokens: each way a call is refused (UNAUTHENTICATED, PERMISSION_DENIED by
// role and by map), what a map-limited token sees, health open to probes, SIGHUP-style reload.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <string>

#include "client/lib/map_client.h"
#include "server/semmap_server.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr char kReader[] = "reader-0123456789abcdef";
constexpr char kLabWriter[] = "labwriter-0123456789abcdef";
constexpr char kAdmin[] = "admin-0123456789abcdef";

class AuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(dir_.File("tokens")) << kReader << " read\n"
                                       << kLabWriter << " write lab\n"
                                       << kAdmin << " admin\n";
    ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = dir_.File("data");
    options.auth_tokens_file = dir_.File("tokens");
    auto server = SemmapServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status().ToString();
    server_ = std::move(server).value();
  }

  std::unique_ptr<MapClient> Client(const std::string& token) const {
    ClientOptions options;
    options.server = server_->address();
    options.token = token;
    return std::make_unique<MapClient>(options);
  }

  // Streams three KNOWN_POSES frames into `map` as `token`; the stream's final status.
  Status IngestAs(const std::string& token, const std::string& map) const {
    auto stream = Client(token)->Ingest(testing::KnownPosesStart(map, ""));
    if (!stream.ok()) return stream.status();
    for (uint64_t i = 0; i < 3; ++i) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation().x() = 0.2 * static_cast<double>(i);
      if (Status s = (*stream)->Write(testing::MakeFrame(i, T)); !s.ok()) break;
    }
    return (*stream)->Finish().status();
  }

  testing::TempDir dir_;
  std::unique_ptr<SemmapServer> server_;
};

TEST_F(AuthTest, CallsWithoutAKnownTokenAreUnauthenticated) {
  EXPECT_EQ(Client("")->ListMaps().status().code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(Client("nobody-0123456789abcdef")->ListMaps().status().code(),
            StatusCode::kUnauthenticated);
  EXPECT_EQ(IngestAs("", "lab").code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(Client("")->GetTrajectory("lab", "s", false).status().code(),
            StatusCode::kUnauthenticated);
  // Health stays open for probes.
  auto health = Client("")->Health();
  ASSERT_TRUE(health.ok()) << health.status().ToString();
  EXPECT_EQ(*health, "SERVING");
}

TEST_F(AuthTest, RolesAndMapsAreEnforced) {
  EXPECT_EQ(IngestAs(kReader, "lab").code(), StatusCode::kPermissionDenied);        // role
  EXPECT_EQ(IngestAs(kLabWriter, "garage").code(), StatusCode::kPermissionDenied);  // map
  ASSERT_TRUE(IngestAs(kLabWriter, "lab").ok());
  ASSERT_TRUE(IngestAs(kAdmin, "garage").ok());

  auto all = Client(kReader)->ListMaps();
  ASSERT_TRUE(all.ok()) << all.status().ToString();
  EXPECT_EQ(all->size(), 2u);
  auto lab_only = Client(kLabWriter)->ListMaps();  // a map-limited token sees its maps only
  ASSERT_TRUE(lab_only.ok()) << lab_only.status().ToString();
  ASSERT_EQ(lab_only->size(), 1u);
  EXPECT_EQ((*lab_only)[0].name, "lab");
  EXPECT_EQ(Client(kLabWriter)->ListSessions("garage").status().code(),
            StatusCode::kPermissionDenied);
  EXPECT_EQ(Client(kLabWriter)->ListSessions("").status().code(),
            StatusCode::kPermissionDenied);  // every map: not this token's
  EXPECT_TRUE(Client(kLabWriter)->ListSessions("lab").ok());

  EXPECT_EQ(Client(kReader)->RemoveMap("garage").status().code(), StatusCode::kPermissionDenied);
  EXPECT_EQ(Client(kLabWriter)->RemoveMap("lab").status().code(), StatusCode::kPermissionDenied);
  EXPECT_TRUE(Client(kAdmin)->RemoveMap("garage").ok());
}

TEST_F(AuthTest, AReloadTakesTheNewTokensAndABrokenFileKeepsTheOld) {
  std::ofstream(dir_.File("tokens")) << "rotated-0123456789abcdef read\n";
  ASSERT_TRUE(server_->ReloadAuthTokens().ok());
  EXPECT_EQ(Client(kReader)->ListMaps().status().code(), StatusCode::kUnauthenticated);
  EXPECT_TRUE(Client("rotated-0123456789abcdef")->ListMaps().ok());
  std::ofstream(dir_.File("tokens")) << "broken\n";
  EXPECT_EQ(server_->ReloadAuthTokens().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(Client("rotated-0123456789abcdef")->ListMaps().ok());
}

}  // namespace
}  // namespace semmap

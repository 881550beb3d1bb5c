// semmapd on a Unix domain socket (--listen unix:/PATH): served to clients on this machine,
// never taking the path from a server that still answers there, never replacing a file that
// is not a socket, and replacing a socket left behind by a server that stopped.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <string>

#include "client/lib/map_client.h"
#include "server/semmap_server.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

class UnixSocketTest : public ::testing::Test {
 protected:
  StatusOr<std::unique_ptr<SemmapServer>> Serve(const testing::TempDir& data) {
    ServerOptions options;
    options.listen = "unix:" + socket_dir_.File("semmapd.sock");
    options.data_dir = data.path();
    return SemmapServer::Start(options);
  }

  static StatusCode ListMapsAt(const std::string& address) {
    ClientOptions options;
    options.server = address;
    options.query_timeout = std::chrono::seconds(10);
    MapClient client(options);
    return client.ListMaps().status().code();
  }

  testing::TempDir socket_dir_, data_;
};

TEST_F(UnixSocketTest, ClientsOnThisMachineAreServed) {
  StatusOr<std::unique_ptr<SemmapServer>> server = Serve(data_);
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  EXPECT_EQ((*server)->address(), "unix:" + socket_dir_.File("semmapd.sock"));
  EXPECT_EQ(ListMapsAt((*server)->address()), StatusCode::kOk);
}

TEST_F(UnixSocketTest, ASecondServerDoesNotTakeThePathFromARunningOne) {
  StatusOr<std::unique_ptr<SemmapServer>> first = Serve(data_);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  testing::TempDir other_data;
  StatusOr<std::unique_ptr<SemmapServer>> second = Serve(other_data);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), StatusCode::kUnavailable);
  EXPECT_NE(second.status().message().find("already listening"), std::string::npos)
      << second.status().ToString();
  EXPECT_EQ(ListMapsAt((*first)->address()), StatusCode::kOk);  // still the first's
}

TEST_F(UnixSocketTest, ASocketLeftBehindIsReplacedAndOtherFilesAreNot) {
  {
    StatusOr<std::unique_ptr<SemmapServer>> stopped = Serve(data_);
    ASSERT_TRUE(stopped.ok()) << stopped.status().ToString();
  }
  // Whether or not gRPC removed its socket file on shutdown, a new server starts there.
  StatusOr<std::unique_ptr<SemmapServer>> again = Serve(data_);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(ListMapsAt((*again)->address()), StatusCode::kOk);
  again->reset();

  testing::TempDir dir;
  std::ofstream(dir.File("notes.txt")) << "not a socket\n";
  ServerOptions options;
  options.listen = "unix:" + dir.File("notes.txt");
  options.data_dir = data_.path();
  StatusOr<std::unique_ptr<SemmapServer>> refused = SemmapServer::Start(options);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  std::ifstream kept(dir.File("notes.txt"));
  std::string line;
  std::getline(kept, line);
  EXPECT_EQ(line, "not a socket");
}

}  // namespace
}  // namespace semmap

#include "server/auth/token_table.h"

#include <gtest/gtest.h>

#include <fstream>

#include "server/auth/authorizer.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr char kTable[] =
    "# semmap tokens\n"
    "reader-0123456789abcdef read\n"
    "\n"
    "writer-0123456789abcdef write kitchen lab   # two maps\n"
    "admin--0123456789abcdef admin\n";

TEST(TokenTableTest, ParsesRolesAndMaps) {
  auto table = TokenTable::Parse(kTable);
  ASSERT_TRUE(table.ok()) << table.status().ToString();
  EXPECT_EQ(table->size(), 3u);
  const TokenGrant* reader = table->Find("reader-0123456789abcdef");
  ASSERT_NE(reader, nullptr);
  EXPECT_EQ(reader->role, Role::kRead);
  EXPECT_TRUE(reader->CoversEveryMap());
  const TokenGrant* writer = table->Find("writer-0123456789abcdef");
  ASSERT_NE(writer, nullptr);
  EXPECT_EQ(writer->role, Role::kWrite);
  EXPECT_EQ(writer->maps, (std::vector<std::string>{"kitchen", "lab"}));
  EXPECT_TRUE(writer->CoversMap("lab"));
  EXPECT_FALSE(writer->CoversMap("garage"));
  EXPECT_EQ(table->Find("admin--0123456789abcdef")->role, Role::kAdmin);
  EXPECT_EQ(table->Find("reader-0123456789abcdeX"), nullptr);
  EXPECT_EQ(table->Find(""), nullptr);
}

TEST(TokenTableTest, BadLinesNameTheLineButNeverTheToken) {
  for (const char* bad :
       {"short read\n", "reader-0123456789abcdef\n", "reader-0123456789abcdef owner\n",
        "reader-0123456789abcdef read bad/map\n",
        "reader-0123456789abcdef read\nreader-0123456789abcdef admin\n", "",
        "# only a comment\n"}) {
    auto table = TokenTable::Parse(bad);
    ASSERT_FALSE(table.ok()) << bad;
    EXPECT_EQ(table.status().code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(table.status().message().find("reader-0123456789abcdef"), std::string::npos)
        << table.status().ToString();
  }
  auto second = TokenTable::Parse("reader-0123456789abcdef read\nx y\n");
  EXPECT_NE(second.status().message().find("line 2"), std::string::npos);
}

TEST(AuthorizerTest, StatusCodesForEachWayACallFails) {
  testing::TempDir dir;
  const std::string path = dir.File("tokens");
  std::ofstream(path) << kTable;
  auto auth = Authorizer::Load(path);
  ASSERT_TRUE(auth.ok()) << auth.status().ToString();
  const std::string lab = "lab", garage = "garage", every;
  Authorizer& a = **auth;
  EXPECT_EQ(a.Check("", Role::kRead, &lab).status().code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(a.Check("Basic abc", Role::kRead, &lab).status().code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(a.Check("Bearer nobody-0123456789abcdef", Role::kRead, &lab).status().code(),
            StatusCode::kUnauthenticated);
  EXPECT_TRUE(a.Check("Bearer reader-0123456789abcdef", Role::kRead, &lab).ok());
  EXPECT_TRUE(a.Check("Bearer reader-0123456789abcdef", Role::kRead, &every).ok());
  EXPECT_EQ(a.Check("Bearer reader-0123456789abcdef", Role::kWrite, &lab).status().code(),
            StatusCode::kPermissionDenied);
  EXPECT_TRUE(a.Check("Bearer writer-0123456789abcdef", Role::kWrite, &lab).ok());
  EXPECT_TRUE(a.Check("Bearer writer-0123456789abcdef", Role::kRead, nullptr).ok());
  EXPECT_EQ(a.Check("Bearer writer-0123456789abcdef", Role::kRead, &garage).status().code(),
            StatusCode::kPermissionDenied);
  EXPECT_EQ(a.Check("Bearer writer-0123456789abcdef", Role::kRead, &every).status().code(),
            StatusCode::kPermissionDenied);
  EXPECT_EQ(a.Check("Bearer writer-0123456789abcdef", Role::kAdmin, &lab).status().code(),
            StatusCode::kPermissionDenied);
  EXPECT_TRUE(a.Check("Bearer admin--0123456789abcdef", Role::kAdmin, &garage).ok());

  // A reload takes the new file; a broken one keeps the tokens in force.
  std::ofstream(path) << "newtoken-0123456789abcdef admin\n";
  ASSERT_TRUE(a.Reload().ok());
  EXPECT_EQ(a.num_tokens(), 1u);
  EXPECT_EQ(a.Check("Bearer reader-0123456789abcdef", Role::kRead, &lab).status().code(),
            StatusCode::kUnauthenticated);
  std::ofstream(path) << "broken\n";
  EXPECT_EQ(a.Reload().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(a.Check("Bearer newtoken-0123456789abcdef", Role::kAdmin, &lab).ok());
  EXPECT_EQ(Authorizer::Load(dir.File("missing")).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap

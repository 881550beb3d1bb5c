#include "client/datasets/image_file.h"

#include <gtest/gtest.h>

#include "tests/testing/temp_dir.h"
#include "tests/unit/client/dataset_test_util.h"

namespace semmap {
namespace {

using testing::TempDir;
using testing::WriteFile;

TEST(ImageFileTest, DetectsPngAndJpegByMagicNumber) {
  TempDir tmp;
  const std::string png = testing::PngHeader(4, 3) + "rest";
  WriteFile(tmp.File("a.jpg"), png);  // the extension does not matter
  StatusOr<EncodedFile> file = ReadImageFile(tmp.File("a.jpg"));
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  EXPECT_EQ(file->format, "png");
  EXPECT_EQ(file->bytes, png);

  const std::string jpeg("\xff\xd8\xff\xe0\0\x10JFIF", 10);
  WriteFile(tmp.File("b.png"), jpeg);
  file = ReadImageFile(tmp.File("b.png"));
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  EXPECT_EQ(file->format, "jpeg");
  EXPECT_EQ(file->bytes, jpeg);
}

TEST(ImageFileTest, UnknownFormatNamesTheFile) {
  TempDir tmp;
  for (const std::string& content :
       {std::string("GIF89a..."), std::string(), std::string("\x89PN")}) {
    WriteFile(tmp.File("x.png"), content);
    StatusOr<EncodedFile> file = ReadImageFile(tmp.File("x.png"));
    ASSERT_FALSE(file.ok());
    EXPECT_EQ(file.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(file.status().message().find(tmp.File("x.png")), std::string::npos);
  }
}

TEST(ImageFileTest, MissingFileIsNotFound) {
  TempDir tmp;
  EXPECT_EQ(ReadImageFile(tmp.File("none.png")).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(PngFileSize(tmp.File("none.png")).status().code(), StatusCode::kNotFound);
}

TEST(PngSizeTest, ReadsIhdr) {
  StatusOr<std::pair<int, int>> size = PngSize(testing::PngHeader(1226, 370));
  ASSERT_TRUE(size.ok()) << size.status().ToString();
  EXPECT_EQ(size->first, 1226);
  EXPECT_EQ(size->second, 370);
  size = PngSize(testing::PngHeader(70000, 0x7fffffff));
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(size->first, 70000);
  EXPECT_EQ(size->second, 0x7fffffff);
}

TEST(PngSizeTest, RejectsBadHeaders) {
  const std::string good = testing::PngHeader(10, 10);
  EXPECT_FALSE(PngSize(good.substr(0, 23)).ok());  // truncated
  std::string bad = good;
  bad[0] = 'x';  // signature
  EXPECT_FALSE(PngSize(bad).ok());
  bad = good;
  bad[12] = 'J';  // chunk type
  EXPECT_FALSE(PngSize(bad).ok());
  bad = good;
  bad[11] = 12;  // IHDR length
  EXPECT_FALSE(PngSize(bad).ok());
  EXPECT_FALSE(PngSize(testing::PngHeader(0, 10)).ok());
  EXPECT_FALSE(PngSize(testing::PngHeader(10, 0x80000000u)).ok());
}

TEST(PngSizeTest, FileSizeReadsOnlyTheHeader) {
  TempDir tmp;
  WriteFile(tmp.File("a.png"), testing::PngHeader(640, 480));
  StatusOr<std::pair<int, int>> size = PngFileSize(tmp.File("a.png"));
  ASSERT_TRUE(size.ok()) << size.status().ToString();
  EXPECT_EQ(*size, std::make_pair(640, 480));
  WriteFile(tmp.File("short.png"), "\x89PNG");
  size = PngFileSize(tmp.File("short.png"));
  ASSERT_FALSE(size.ok());
  EXPECT_NE(size.status().message().find("short.png"), std::string::npos);
}

}  // namespace
}  // namespace semmap

#include "common/logging.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(LoggingTest, LevelsParseAndNameEachOther) {
  for (LogLevel level :
       {LogLevel::kDebug, LogLevel::kInfo, LogLevel::kWarning, LogLevel::kError, LogLevel::kOff}) {
    StatusOr<LogLevel> parsed = ParseLogLevel(LogLevelName(level));
    ASSERT_TRUE(parsed.ok()) << LogLevelName(level);
    EXPECT_EQ(*parsed, level);
  }
  EXPECT_EQ(*ParseLogLevel("warn"), LogLevel::kWarning);
  const StatusOr<LogLevel> bad = ParseLogLevel("verbose");
  EXPECT_EQ(bad.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("debug, info, warning, error, off"), std::string::npos);
}

TEST(LoggingTest, TheLevelDecidesWhatIsWritten) {
  const LogLevel before = GetLogLevel();
  SetLogLevel(LogLevel::kWarning);
  EXPECT_EQ(GetLogLevel(), LogLevel::kWarning);
  EXPECT_FALSE(Logger().should_log(spdlog::level::info));
  EXPECT_TRUE(Logger().should_log(spdlog::level::warn));
  testing::internal::CaptureStderr();
  LogInfo("not written {}", 1);
  LogWarning("written {}", 2);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(err.find("not written"), std::string::npos) << err;
  EXPECT_NE(err.find("warning: written 2"), std::string::npos) << err;
  SetLogLevel(LogLevel::kOff);
  EXPECT_FALSE(Logger().should_log(spdlog::level::err));
  SetLogLevel(before);
}

}  // namespace
}  // namespace semmap

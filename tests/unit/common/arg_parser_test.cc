#include "common/arg_parser.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(ArgParserTest, FlagsSwitchesAndPositionals) {
  ArgParser p;
  p.AddFlag("map", "M", "map name");
  p.AddFlag("rate", "HZ", "rate");
  p.AddSwitch("json", "json output");
  const char* argv[] = {"semmap", "ingest", "--map", "lab", "DIR", "--rate=30", "--json"};
  ASSERT_TRUE(p.Parse(7, argv).ok());
  EXPECT_EQ(p.Get("map"), "lab");
  EXPECT_TRUE(p.Has("json"));
  EXPECT_EQ(*p.GetDouble("rate", 0), 30.0);
  ASSERT_EQ(p.positional().size(), 2u);
  EXPECT_EQ(p.positional()[1], "DIR");
}

TEST(ArgParserTest, OnOffFlags) {
  ArgParser p;
  p.AddFlag("final-ba", "on|off", "");
  p.AddFlag("objects", "on|off", "");
  p.AddFlag("layers", "on|off", "");
  const char* argv[] = {"semmapd", "--final-ba", "off", "--objects=on", "--layers", "yes"};
  ASSERT_TRUE(p.Parse(6, argv).ok());
  EXPECT_FALSE(*p.GetOnOff("final-ba", true));
  EXPECT_TRUE(*p.GetOnOff("objects", false));
  const StatusOr<bool> bad = p.GetOnOff("layers", true);
  ASSERT_EQ(bad.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(bad.status().message(), "--layers must be on or off, got 'yes'");
  ArgParser unset;
  unset.AddFlag("final-ba", "on|off", "");
  EXPECT_TRUE(*unset.GetOnOff("final-ba", true));
}

TEST(ArgParserTest, ShortFlags) {
  ArgParser p;
  p.AddFlag("o", "FILE", "output");
  p.AddFlag("map", "M", "map");
  const char* argv[] = {"x", "-o", "out.txt", "--map", "m", "-"};
  ASSERT_TRUE(p.Parse(6, argv).ok());
  EXPECT_EQ(p.Get("o"), "out.txt");
  ASSERT_EQ(p.positional().size(), 1u);  // a lone "-" (stdin) stays positional
  EXPECT_NE(p.Usage().find("  -o FILE"), std::string::npos);
  const char* long_o[] = {"x", "--o", "f"};
  ArgParser q;
  q.AddFlag("o", "FILE", "output");
  EXPECT_FALSE(q.Parse(3, long_o).ok());
  const char* short_map[] = {"x", "-m", "f"};
  ArgParser r;
  r.AddFlag("map", "M", "map");
  EXPECT_FALSE(r.Parse(3, short_map).ok());
}

TEST(ArgParserTest, Errors) {
  ArgParser p;
  p.AddFlag("rate", "HZ", "rate");
  p.AddSwitch("json", "json");
  const char* unknown[] = {"x", "--nope"};
  EXPECT_EQ(p.Parse(2, unknown).code(), StatusCode::kInvalidArgument);
  ArgParser q;
  q.AddFlag("rate", "HZ", "rate");
  const char* missing[] = {"x", "--rate"};
  EXPECT_EQ(q.Parse(2, missing).code(), StatusCode::kInvalidArgument);
  ArgParser r;
  r.AddFlag("rate", "HZ", "rate");
  const char* bad[] = {"x", "--rate", "fast"};
  ASSERT_TRUE(r.Parse(3, bad).ok());
  EXPECT_FALSE(r.GetDouble("rate", 0).ok());
}

}  // namespace
}  // namespace semmap

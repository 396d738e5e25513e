#include "common/map/map_name.h"

#include <gtest/gtest.h>

#include <string>

namespace sceneloc {
namespace {

// Plain file stems are names; anything that could leave the maps folder, hide, or be empty
// is not, and the problem says why.
TEST(MapNameTest, OnlyPlainStemsAreNames) {
  for (const std::string ok : {std::string("campus"), std::string("site.v2"), std::string("a_b-c"),
                               std::string("A1"), std::string(255, 'x')}) {
    EXPECT_TRUE(IsValidMapName(ok)) << ok;
    EXPECT_EQ(MapNameProblem(ok), "");
  }
  EXPECT_EQ(MapNameProblem(""), "a map name must not be empty");
  EXPECT_EQ(MapNameProblem(std::string(256, 'x')), "a map name has at most 255 characters");
  EXPECT_EQ(MapNameProblem(".hidden"), "a map name must not start with '.'");
  EXPECT_EQ(MapNameProblem(".."), "a map name must not start with '.'");
  for (const char* bad : {"a/../etc", "a/b", "a b", "caf\xc3\xa9", "x\n"}) {
    EXPECT_FALSE(IsValidMapName(bad)) << bad;
    EXPECT_EQ(MapNameProblem(bad), "a map name holds only letters, digits, '_', '-' and '.'");
  }
}

// A file in the maps folder is a map when it ends in .scnl and its stem is a valid name;
// SaveMap's temporaries, hidden files and other files are not.
TEST(MapNameTest, MapNameOfFile) {
  EXPECT_EQ(MapNameOfFile("site.scnl"), "site");
  EXPECT_EQ(MapNameOfFile("site.v2.scnl"), "site.v2");
  EXPECT_EQ(MapNameOfFile("site.scnl.tmp.1234"), "");
  EXPECT_EQ(MapNameOfFile(".site.scnl"), "");
  EXPECT_EQ(MapNameOfFile(".scnl"), "");
  EXPECT_EQ(MapNameOfFile("my map.scnl"), "");
  EXPECT_EQ(MapNameOfFile("notes.txt"), "");
}

}  // namespace
}  // namespace sceneloc

// ParseMemorySize (tools/memory_size.h), the parser of --memory-limit; the
// budget it feeds is tests/tools/memory_budget_test.cc.
#include <gtest/gtest.h>

#include "tools/memory_size.h"

namespace graphslam::tools {
namespace {

TEST(ParseMemorySize, SuffixesArePowersOf1024) {
  EXPECT_EQ(*ParseMemorySize("1000"), 1000);
  EXPECT_EQ(*ParseMemorySize("64k"), 64 * 1024);
  EXPECT_EQ(*ParseMemorySize("512M"), int64_t{512} << 20);
  EXPECT_EQ(*ParseMemorySize("2G"), int64_t{2} << 30);
  EXPECT_EQ(*ParseMemorySize("2GiB"), int64_t{2} << 30);
  EXPECT_EQ(*ParseMemorySize("1.5g"), int64_t{3} << 29);
  EXPECT_EQ(*ParseMemorySize("1T"), int64_t{1} << 40);
}

TEST(ParseMemorySize, GarbageIsInvalidArgumentNamingTheText) {
  for (const char* text : {"", "lots", "-1G", "0", "2X", "G"}) {
    StatusOr<int64_t> parsed = ParseMemorySize(text);
    ASSERT_FALSE(parsed.ok()) << text;
    std::string quoted = "'";  // (built by append: GCC 12 warns -Wrestrict on "'" + string)
    quoted.append(text).push_back('\'');
    EXPECT_NE(parsed.status().ToString().find(quoted), std::string::npos);
  }
}

}  // namespace
}  // namespace graphslam::tools

#include "core/status.h"

#include <gtest/gtest.h>

namespace graphslam {
namespace {

TEST(Status, OkHasNoMessage) {
  Status status = Status::Ok();
  EXPECT_TRUE(status.ok());
  EXPECT_EQ(status.ToString(), "OK");
}

TEST(Status, ErrorCarriesCodeAndMessage) {
  Status status = Status::Corruption("a.g2o:3: bad field");
  EXPECT_FALSE(status.ok());
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.ToString(), "Corruption: a.g2o:3: bad field");
  EXPECT_EQ(status.WithContext("loading").message(), "loading: a.g2o:3: bad field");
}

StatusOr<int> Half(int x) {
  if (x % 2 != 0) return Status::InvalidArgument("odd");
  return x / 2;
}

Status UseHalf(int x, int* out) {
  GS_ASSIGN_OR_RETURN(int half, Half(x));
  *out = half;
  return Status::Ok();
}

TEST(StatusOr, PropagatesValueOrError) {
  int out = 0;
  EXPECT_TRUE(UseHalf(8, &out).ok());
  EXPECT_EQ(out, 4);
  Status status = UseHalf(3, &out);
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(out, 4);
}

}  // namespace
}  // namespace graphslam

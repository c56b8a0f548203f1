// RejectedPairs (partition/association/internal/rejected_pairs.h): the undo memory that
// keeps the association from merging and undoing one pair forever.
#include "partition/association/internal/rejected_pairs.h"

#include <gtest/gtest.h>

namespace graphslam::partition::internal {
namespace {

TEST(RejectedPairs, UndoneAfterAFullSolveIsForbiddenAtOnce) {
  RejectedPairs rejected;
  EXPECT_FALSE(rejected.IsForbidden(3, 7));
  rejected.RecordUndo(7, 3, /*after_full_solve=*/true);
  EXPECT_TRUE(rejected.IsForbidden(3, 7));
  EXPECT_TRUE(rejected.IsForbidden(7, 3));
  EXPECT_FALSE(rejected.IsForbidden(3, 8));
}

TEST(RejectedPairs, UndoneOnRefittedFeaturesIsForgivenOnceNotForever) {
  RejectedPairs rejected;
  rejected.RecordUndo(4, 9, /*after_full_solve=*/false);
  EXPECT_FALSE(rejected.IsForbidden(4, 9));  // may come back after a full solve
  rejected.RecordUndo(9, 4, /*after_full_solve=*/false);
  EXPECT_TRUE(rejected.IsForbidden(4, 9));  // the second undo is final
  EXPECT_EQ(rejected.forbidden().size(), 1u);
}

TEST(RejectedPairs, SecondChanceAfterAFullSolveWhenAsked) {
  RejectedPairs rejected(/*full_solve_undos=*/2);
  rejected.RecordUndo(1, 2, /*after_full_solve=*/true);
  EXPECT_FALSE(rejected.IsForbidden(1, 2));
  rejected.RecordUndo(1, 2, /*after_full_solve=*/true);
  EXPECT_TRUE(rejected.IsForbidden(1, 2));
  // Never more than kMaxUndos, whatever is asked.
  RejectedPairs capped(/*full_solve_undos=*/5);
  capped.RecordUndo(1, 2, true);
  capped.RecordUndo(1, 2, true);
  EXPECT_TRUE(capped.IsForbidden(1, 2));
}

}  // namespace
}  // namespace graphslam::partition::internal

// RejectedPairs: which pairs of input features the association must not merge
// again (partition/association/association_driver.h, section 6 property 3 of Thrun &
// Montemerlo 2006: a merge later evidence rejects is undone).
//
// Policy. A merge undone right after a full Levenberg-Marquardt solve is
// rejected for good: the whole map agreed it does not fit. A merge undone on
// features re-fitted with the poses held (refit_between_undos) may be proposed
// again once a full solve has moved the poses, but only kMaxUndos - 1 times:
// without a limit such a pair can be merged after every full solve and undone
// after every re-fit until max_rounds (seen on the 20 000-pose campus: ~25
// pairs per round for 23 rounds).
//
// THREAD SAFETY: none (one association run). ALLOCATION: O(undone pairs).
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <utility>

namespace graphslam::partition::internal {

class RejectedPairs {
 public:
  static constexpr int kMaxUndos = 2;
  using Pair = std::pair<int32_t, int32_t>;

  // full_solve_undos: undos after a full solve that forbid a pair (1: the
  // first; 2: it may come back once, e.g. when it was undone on a map still
  // bent by other, wrong merges). Never more than kMaxUndos.
  explicit RejectedPairs(int full_solve_undos = 1)
      : full_solve_undos_(std::clamp(full_solve_undos, 1, kMaxUndos)) {}

  // Records that the merge of input features a and b was undone.
  void RecordUndo(int32_t a, int32_t b, bool after_full_solve) {
    const Pair pair = std::minmax(a, b);
    const int undos = ++undos_[pair];
    if ((after_full_solve && undos >= full_solve_undos_) || undos >= kMaxUndos)
      forbidden_.insert(pair);
  }
  bool IsForbidden(int32_t a, int32_t b) const { return forbidden_.count(std::minmax(a, b)) > 0; }
  const std::set<Pair>& forbidden() const { return forbidden_; }

 private:
  int full_solve_undos_;
  std::map<Pair, int> undos_;  // undos so far
  std::set<Pair> forbidden_;
};

}  // namespace graphslam::partition::internal

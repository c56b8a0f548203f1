// SuiteSparse_time (core/suitesparse_clock.h): CHOLMOD's supernodal
// factorization still makes its BLAS and LAPACK calls (and counts them), but
// its clock reads are this library's constant, so the time statistics it
// keeps for them stay 0.
#include "core/suitesparse_clock.h"

#include <gtest/gtest.h>
#include <suitesparse/cholmod.h>

namespace graphslam::core {
namespace {

TEST(SuiteSparseClock, ReadsAConstantZero) {
  EXPECT_EQ(SuiteSparse_time(), 0.0);
  EXPECT_EQ(SuiteSparse_time(), 0.0);
}

// A dense 400 x 400 SPD matrix (one supernode: one dpotrf of a few ms, whose
// time CHOLMOD would add up with a real clock).
TEST(SuiteSparseClock, SupernodalFactorizationAddsNoTime) {
  constexpr int n = 400;
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  common.supernodal = CHOLMOD_SUPERNODAL;
  cholmod_sparse* a = cholmod_allocate_sparse(n, n, n * (n + 1) / 2, /*sorted=*/1,
                                              /*packed=*/1, /*stype=*/1, CHOLMOD_REAL, &common);
  ASSERT_NE(a, nullptr);
  int* p = static_cast<int*>(a->p);
  int* rows = static_cast<int*>(a->i);
  double* x = static_cast<double*>(a->x);
  int k = 0;
  for (int col = 0; col < n; ++col) {  // upper triangle: 1 off the diagonal, n + 1 on it
    p[col] = k;
    for (int row = 0; row <= col; ++row, ++k) {
      rows[k] = row;
      x[k] = row == col ? n + 1.0 : 1.0;
    }
  }
  p[n] = k;
  cholmod_factor* factor = cholmod_analyze(a, &common);
  ASSERT_NE(factor, nullptr);
  ASSERT_TRUE(factor->is_super);
  ASSERT_TRUE(cholmod_factorize(a, factor, &common));
  EXPECT_EQ(common.status, CHOLMOD_OK);
  EXPECT_GT(common.CHOLMOD_CPU_POTRF_CALLS, 0);
  EXPECT_EQ(common.CHOLMOD_CPU_POTRF_TIME, 0.0);
  EXPECT_EQ(common.CHOLMOD_CPU_SYRK_TIME, 0.0);
  EXPECT_EQ(common.CHOLMOD_CPU_GEMM_TIME, 0.0);
  EXPECT_EQ(common.CHOLMOD_CPU_TRSM_TIME, 0.0);
  cholmod_free_factor(&factor, &common);
  cholmod_free_sparse(&a, &common);
  cholmod_finish(&common);
}

}  // namespace
}  // namespace graphslam::core

# Tests of the linear algebra.

# Tests of the solver.

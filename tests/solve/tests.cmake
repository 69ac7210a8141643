multibond_test(solve/integrator_test.cc LIBS multibond::solve LABELS unit)
multibond_test(solve/eigen_linear_solver_test.cc LIBS multibond::solve LABELS unit)
multibond_test(solve/sparse_jacobian_test.cc LIBS multibond::solve LABELS unit)

multibond_test(solve/integrator_test.cc LIBS multibond::solve LABELS unit)

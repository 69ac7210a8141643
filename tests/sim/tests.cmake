multibond_test(sim/compare_test.cc LIBS multibond::io LABELS unit)

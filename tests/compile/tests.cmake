multibond_test(compile/equations_test.cc LIBS multibond::compile LABELS unit)

multibond_test(causality/causality_test.cc LIBS multibond::causality LABELS unit)

multibond_test(causality/causality_test.cc LIBS multibond::causality LABELS unit)
multibond_test(causality/repair_test.cc LIBS multibond::io LABELS unit)

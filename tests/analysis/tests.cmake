multibond_test(analysis/linearize_test.cc LIBS multibond::analysis LABELS unit)

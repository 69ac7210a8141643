multibond_test(analysis/linearize_test.cc LIBS multibond::analysis LABELS unit)
multibond_test(analysis/modes_test.cc LIBS multibond::analysis LABELS unit)
multibond_test(analysis/bode_test.cc LIBS multibond::analysis LABELS unit)
multibond_test(analysis/linear_files_test.cc LIBS multibond::analysis LABELS unit)

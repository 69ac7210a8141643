multibond_test(core/process_test.cc LIBS multibond::core LABELS unit)

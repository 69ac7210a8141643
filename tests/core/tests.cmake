multibond_test(core/utf8_test.cc LIBS multibond::core LABELS unit)

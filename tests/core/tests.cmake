multibond_test(core/identifier_test.cc LIBS multibond::core LABELS unit)
multibond_test(core/units_test.cc LIBS multibond::core LABELS unit)
multibond_test(core/utf8_test.cc LIBS multibond::core LABELS unit)
multibond_test(core/process_test.cc LIBS multibond::core LABELS unit)

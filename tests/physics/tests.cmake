multibond_test(physics/examples_test.cc LIBS multibond::io LABELS physics)

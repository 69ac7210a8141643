multibond_test(mech/rigid_body_test.cc LIBS multibond::sim multibond::mech LABELS physics)

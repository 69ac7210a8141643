multibond_test(mech/mechanism_test.cc LIBS multibond::sim multibond::mech LABELS physics)
multibond_test(mech/docs_mechanisms_test.cc LIBS multibond::io LABELS physics)
multibond_test(mech/gear_contact_test.cc LIBS multibond::io LABELS physics)
multibond_test(mech/joint_kinds_test.cc LIBS multibond::io LABELS physics)

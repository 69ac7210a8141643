multibond_test(repair/suggest_test.cc LIBS multibond::io LABELS unit)
multibond_test(repair/repaired_physics_test.cc LIBS multibond::io LABELS physics)

multibond_test(sim/compare_test.cc LIBS multibond::io LABELS unit)
multibond_test(sim/joint_coordinates_test.cc LIBS multibond::io LABELS unit)
multibond_test(sim/joint_coordinates_joints_test.cc LIBS multibond::io LABELS physics)

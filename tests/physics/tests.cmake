multibond_test(physics/examples_test.cc LIBS multibond::io LABELS physics)
multibond_test(physics/differential_test.cc LIBS multibond::io LABELS physics)
target_include_directories(physics_differential_test PRIVATE ${PROJECT_SOURCE_DIR}/examples/differential)
multibond_test(physics/ideal_constraints_test.cc LIBS multibond::io LABELS physics)

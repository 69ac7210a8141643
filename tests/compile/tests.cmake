multibond_test(compile/equations_test.cc LIBS multibond::compile LABELS unit)
multibond_test(compile/compiled_model_test.cc LIBS multibond::sim LABELS unit)
multibond_test(compile/jacobian_pattern_test.cc LIBS multibond::io LABELS unit)
multibond_test(compile/algebraic_loop_test.cc LIBS multibond::io LABELS unit)

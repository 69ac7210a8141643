multibond_test(io/model_loader_test.cc LIBS multibond::io LABELS unit)
multibond_test(io/dot_writer_test.cc LIBS multibond::io LABELS unit)
multibond_test(io/model_format_doc_test.cc LIBS multibond::io LABELS unit)
multibond_test(io/bad_models_test.cc LIBS multibond::io LABELS unit)

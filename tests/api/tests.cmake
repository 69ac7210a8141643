# The public C++ API, through its shared library and public headers only (multibond::api is what
# the installed package exports as multibond::multibond).
multibond_test(api/model_test.cc LIBS multibond::api LABELS api)
multibond_test(api/simulation_test.cc LIBS multibond::api LABELS api)
multibond_test(api/results_test.cc LIBS multibond::api LABELS api)
multibond_test(api/linear_test.cc LIBS multibond::api LABELS api)

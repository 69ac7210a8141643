multibond_test(cli/cli_test.cc LIBS nlohmann_json::nlohmann_json LABELS cli)
multibond_test(cli/hostile_test.cc LABELS cli)
multibond_test(cli/equation_examples_test.cc LIBS nlohmann_json::nlohmann_json LABELS cli)
multibond_test(cli/linear_cli_test.cc LIBS nlohmann_json::nlohmann_json LABELS cli)
multibond_test(cli/events_cli_test.cc LIBS nlohmann_json::nlohmann_json LABELS cli)
# The readers of results.mat and results.h5 (tests/io/tests.cmake says why these): found here too,
# since this fragment is read first.
find_program(MULTIBOND_SYSTEM_PYTHON NAMES python3 PATHS /usr/bin NO_DEFAULT_PATH)
find_program(MULTIBOND_OCTAVE NAMES octave)
multibond_test(cli/formats_cli_test.cc LIBS multibond::core nlohmann_json::nlohmann_json LABELS cli)
multibond_test_setting(cli DEFINITIONS
  MULTIBOND_SYSTEM_PYTHON="$<$<BOOL:${MULTIBOND_SYSTEM_PYTHON}>:${MULTIBOND_SYSTEM_PYTHON}>"
  MULTIBOND_OCTAVE="$<$<BOOL:${MULTIBOND_OCTAVE}>:${MULTIBOND_OCTAVE}>")
multibond_test(cli/sweep_cli_test.cc LABELS cli)
multibond_test_setting(cli DEFINITIONS MULTIBOND_MPIEXEC="$<$<BOOL:${MULTIBOND_HAVE_MPI}>:${MPIEXEC_EXECUTABLE}>")
multibond_test(cli/view_cli_test.cc LABELS cli)

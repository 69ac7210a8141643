multibond_test(cli/cli_test.cc LIBS nlohmann_json::nlohmann_json LABELS cli)
add_dependencies(cli_cli_test multibond_cli)
multibond_test(cli/hostile_test.cc LABELS cli)
add_dependencies(cli_hostile_test multibond_cli)

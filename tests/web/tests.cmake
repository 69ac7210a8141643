# The results page in a real browser (tests/web/page_test.mjs): headless Chromium (Debian's
# chromium package) driven by puppeteer-core from web/node_modules (npm ci, scripts/install-deps).
# Skipped (exit 77) with the reason when Chromium or web/node_modules is missing.
find_program(MULTIBOND_CHROMIUM NAMES chromium chromium-browser PATHS /usr/bin)
if(MULTIBOND_NODE)
  add_test(NAME web.results_page
    COMMAND ${MULTIBOND_NODE} ${CMAKE_CURRENT_LIST_DIR}/page_test.mjs
      --cli $<TARGET_FILE:multibond_cli> --source ${PROJECT_SOURCE_DIR} --work ${CMAKE_CURRENT_BINARY_DIR}/web-page-test
      --chromium "$<IF:$<BOOL:${MULTIBOND_CHROMIUM}>,${MULTIBOND_CHROMIUM},/usr/bin/chromium>")
  set_tests_properties(web.results_page PROPERTIES SKIP_RETURN_CODE 77 LABELS "cli;web" TIMEOUT 600 ENVIRONMENT "MULTIBOND_JIT_KEEP=0")
else()
  message(STATUS "multibond: no browser test of the results page (needs node)")
endif()

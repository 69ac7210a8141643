# The interactive results page's script and style (web/, docs/plots.md): web/src/page.js with
# uPlot and three.js bundled by esbuild into <build>/web/multibond-page.js and .css, which
# `multibond plot` copies next to each results page. The JavaScript packages come from npm at
# build time (`npm ci` in web/, run by scripts/install-deps) and are never needed at run time:
# the installed files live in <prefix>/share/multibond/web. Without node or web/node_modules the
# page is written without its interactive part (with a note saying so).
find_program(MULTIBOND_NODE NAMES node nodejs)
set(MULTIBOND_WEB_BUILD_DIR ${PROJECT_BINARY_DIR}/web)
set(MULTIBOND_WEB_SOURCE_DIR ${PROJECT_SOURCE_DIR}/web)
if(MULTIBOND_NODE AND EXISTS ${MULTIBOND_WEB_SOURCE_DIR}/node_modules/esbuild/package.json)
  set(MULTIBOND_WEB ON)
  set(outputs ${MULTIBOND_WEB_BUILD_DIR}/multibond-page.js ${MULTIBOND_WEB_BUILD_DIR}/multibond-page.css)
  file(GLOB web_sources CONFIGURE_DEPENDS ${MULTIBOND_WEB_SOURCE_DIR}/src/*)
  add_custom_command(OUTPUT ${outputs}
    COMMAND ${MULTIBOND_NODE} ${MULTIBOND_WEB_SOURCE_DIR}/build.mjs ${MULTIBOND_WEB_BUILD_DIR}
    DEPENDS ${web_sources} ${MULTIBOND_WEB_SOURCE_DIR}/build.mjs ${MULTIBOND_WEB_SOURCE_DIR}/package-lock.json
    WORKING_DIRECTORY ${MULTIBOND_WEB_SOURCE_DIR}
    COMMENT "Bundling the results page's script (web/)"
    VERBATIM)
  add_custom_target(multibond_web ALL DEPENDS ${outputs})
  install(FILES ${outputs} DESTINATION ${CMAKE_INSTALL_DATADIR}/multibond/web)
else()
  set(MULTIBOND_WEB OFF)
  message(STATUS "multibond: the results page has no interactive part (needs node and `npm ci` in web/: scripts/install-deps)")
endif()
# Where an uninstalled multibond finds the bundle (plot_web.cc, FindPageAssets).
set_source_files_properties(${PROJECT_SOURCE_DIR}/src/multibond/io/plot_web.cc DIRECTORY ${PROJECT_SOURCE_DIR}/src
  PROPERTIES COMPILE_DEFINITIONS MULTIBOND_WEB_BUILD_DIR="${MULTIBOND_WEB_BUILD_DIR}")

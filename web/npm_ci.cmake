# Runs `npm ci` in web/ only when node_modules is missing or older than package-lock.json, so several build
# directories sharing the source tree install once. Called by the web_assets target (web/CMakeLists.txt).
set(hidden_lock "${WEB_DIR}/node_modules/.package-lock.json")
if(EXISTS "${hidden_lock}" AND NOT "${WEB_DIR}/package-lock.json" IS_NEWER_THAN "${hidden_lock}")
  return()
endif()
message(STATUS "web: npm ci (package-lock.json changed or node_modules missing)")
execute_process(COMMAND "${NPM}" ci --no-audit --no-fund WORKING_DIRECTORY "${WEB_DIR}" RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "web: npm ci failed (${result}); the dashboard needs web/node_modules/chart.js")
endif()

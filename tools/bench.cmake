# SPDX-License-Identifier: MIT
# bench_search: search-stage and end-to-end timings, OpenCL vs reference
# (a developer tool: it links pkss_static to reach the search internals).
#   POCL_CACHE_DIR=/tmp/pocl ./tools/bench_search [--runs 5] [--quick]
if(TARGET pkss_static)
  add_executable(bench_search "${CMAKE_CURRENT_LIST_DIR}/bench_search.c")
  target_link_libraries(bench_search PRIVATE pkss_static m)
  target_include_directories(bench_search PRIVATE "${PROJECT_SOURCE_DIR}/tests")
  set(PKSS_BENCH_DATA_DIR "${PROJECT_SOURCE_DIR}/../shared/data" CACHE PATH
      "Folder of the shared real scans used by bench_search")
  target_compile_definitions(bench_search PRIVATE
    "PKSS_DATA_DIR=\"${PKSS_BENCH_DATA_DIR}\"")
  set_target_properties(bench_search PROPERTIES
    C_STANDARD 11 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
endif()

# --- conf_dump (the confidence model's features, tools/confidence/fit.py);
# a development tool, absent from the Python sdist ---
if(TARGET pkss_static AND EXISTS "${CMAKE_CURRENT_LIST_DIR}/confidence/conf_dump.c")
  add_executable(conf_dump "${CMAKE_CURRENT_LIST_DIR}/confidence/conf_dump.c")
  target_link_libraries(conf_dump PRIVATE pkss_static m)
  target_include_directories(conf_dump PRIVATE "${PROJECT_SOURCE_DIR}/src"
                             "${PROJECT_SOURCE_DIR}/kernels")
  set_target_properties(conf_dump PROPERTIES
    C_STANDARD 11 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
endif()

# --- pkss_count (pkss_dump with the ICP's lookups counted, in a
# PKSS_COUNT_WORK build; a developer tool) ---
if(TARGET pkss_static AND PKSS_COUNT_WORK AND EXISTS "${CMAKE_CURRENT_LIST_DIR}/identity/pkss_count.c")
  add_executable(pkss_count "${CMAKE_CURRENT_LIST_DIR}/identity/pkss_count.c")
  target_link_libraries(pkss_count PRIVATE pkss_static m)
  target_include_directories(pkss_count PRIVATE "${PROJECT_SOURCE_DIR}/src/refine")
  set_target_properties(pkss_count PROPERTIES
    C_STANDARD 11 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
endif()

# --- bench_thin (voxel thinning of huge clouds, SPEC 2.1; a developer tool) ---
if(TARGET pkss_static)
  add_executable(bench_thin "${CMAKE_CURRENT_LIST_DIR}/bench_thin.c")
  target_link_libraries(bench_thin PRIVATE pkss_static m)
  target_include_directories(bench_thin PRIVATE "${PROJECT_SOURCE_DIR}/src"
                             "${PROJECT_SOURCE_DIR}/kernels")
  set_target_properties(bench_thin PROPERTIES
    C_STANDARD 11 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
endif()

# --- pose_probe (scores a known pose with pkss's measures and refines from it:
# is a miss the search's or the objective's? a developer tool) ---
if(TARGET pkss_static)
  add_executable(pose_probe "${CMAKE_CURRENT_LIST_DIR}/pose_probe.c")
  target_link_libraries(pose_probe PRIVATE pkss_static m)
  target_include_directories(pose_probe PRIVATE "${PROJECT_SOURCE_DIR}/src"
                             "${PROJECT_SOURCE_DIR}/kernels")
  set_target_properties(pose_probe PROPERTIES
    C_STANDARD 11 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
endif()

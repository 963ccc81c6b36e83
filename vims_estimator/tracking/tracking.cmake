# Visual front end (issue 4): ROS-free feature tracker library and its tests.
# Included from vims_estimator/CMakeLists.txt with include(tracking/tracking.cmake); paths are
# relative to this file so the include works from any directory.
add_library(vims_tracking_core
  ${CMAKE_CURRENT_LIST_DIR}/src/tracker_options.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/tracking_stages.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/feature_tracker.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/feature_drawing.cpp
)
target_include_directories(vims_tracking_core PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
target_link_libraries(vims_tracking_core PUBLIC vims_common_core ${OpenCV_LIBS} Eigen3::Eigen)

vims_add_unit_test(test_vims_tracking
  ${CMAKE_CURRENT_LIST_DIR}/test/test_tracker_options.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test/test_tracking_stages.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test/test_feature_tracker.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test/test_feature_drawing.cpp
  LIBS vims_tracking_core)

# On simulated sequences (needs the bag reader and the simulator): tank30 from the shared
# fixture sim_tank30 (test/CMakeLists.txt), and a short sequence with a lamp failure and an
# image gap that only these tests use (about 6 s to simulate).
if(TARGET vims_ros AND TARGET vims_sim AND CATKIN_ENABLE_TESTING)
  add_test(NAME fixture_sim_tank_blackout10
    COMMAND $<TARGET_FILE:vims_sim> --scenario tank --duration 10 --seed 5
            --camera-blackout 4:6 --camera-off 7:7.5 --out ${PROJECT_BINARY_DIR}/test_data/tank_blackout10)
  set_tests_properties(fixture_sim_tank_blackout10 PROPERTIES FIXTURES_SETUP sim_tank_blackout10 TIMEOUT 600)

  vims_add_unit_test(test_vims_tracking_sequence
    ${CMAKE_CURRENT_LIST_DIR}/test/test_tracker_on_sequence.cpp
    LIBS vims_tracking_core vims_ros)
  vims_require_sequence(_ctest_vims_gtest_test_vims_tracking_sequence sim_tank30)
  set_property(TEST _ctest_vims_gtest_test_vims_tracking_sequence APPEND PROPERTY FIXTURES_REQUIRED sim_tank_blackout10)

  # Front-end CPU time per frame and a checksum of the tracks on a sequence (docs/frontends.md).
  add_executable(bench_vims_tracker ${CMAKE_CURRENT_LIST_DIR}/bench/bench_tracker.cpp)
  target_link_libraries(bench_vims_tracker vims_tracking_core vims_ros)
  set_target_properties(bench_vims_tracker PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/lib/vims)
endif()

# The build without ROS (CMakeLists.txt includes this when catkin is absent or NE_WITH_ROS is OFF):
# the ROS-free core, the command-line tools and the Python module networked_estimation._core, with
# plain CMake and the packages Eigen, yaml-cpp, nlohmann-json, GeographicLib and pybind11 only
# (scripts/install_deps.sh --core). No nodelets, messages, launch files or graph tests.
#
#   cmake -S . -B build -DNE_WITH_ROS=OFF && cmake --build build -j2
#     build/bin/            simulate, replay, score, montecarlo, analyze, make_model, fit_link
#     build/python/         the package networked_estimation (PYTHONPATH=build/python)
#   pip install --no-build-isolation .    (setup.py runs this build for the module alone)
#
# NE_BUILD_TOOLS=OFF builds the core and the Python module only (what setup.py builds).
option(NE_BUILD_TOOLS "Build without ROS: also the command-line tools" ON)
if(NE_BUILD_TOOLS)
  message(STATUS "networked_estimation: the build without ROS (NE_WITH_ROS=OFF): the core, the tools, the Python module")
else()
  message(STATUS "networked_estimation: the build without ROS (NE_WITH_ROS=OFF): the core and the Python module")
endif()

find_package(Eigen3 REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3.7.3 REQUIRED)
find_path(GeographicLib_INCLUDE_DIR GeographicLib/LocalCartesian.hpp)
find_library(GeographicLib_LIBRARY NAMES GeographicLib Geographic)
if(NOT GeographicLib_INCLUDE_DIR OR NOT GeographicLib_LIBRARY)
  message(FATAL_ERROR "GeographicLib not found: install it (Debian and Ubuntu: libgeographiclib-dev or "
                      "libgeographic-dev; scripts/install_deps.sh --core)")
endif()
# bzip2 and lz4: the core reads ROS bags itself (io/ros_bag.cpp: fit_link, analyze --bag, trace
# channels), whose chunks may be compressed with either; no ROS is needed to read them.
find_package(BZip2 REQUIRED)
find_path(LZ4_INCLUDE_DIR lz4frame.h)
find_library(LZ4_LIBRARY NAMES lz4)
if(NOT LZ4_INCLUDE_DIR OR NOT LZ4_LIBRARY)
  message(FATAL_ERROR "lz4 not found: install it (Debian and Ubuntu: liblz4-dev; scripts/install_deps.sh --core)")
endif()
find_package(Python3 COMPONENTS Interpreter Development REQUIRED)
find_package(pybind11 CONFIG REQUIRED)

set(CMAKE_RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
set(CMAKE_LIBRARY_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/lib)
set(CMAKE_ARCHIVE_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/lib)
# The core is a static library here: the tools and the module carry it, nothing to find at run time.
# All of it: the simulator's sensor outputs use online/'s datum reader, and that geodesy/.
add_library(${PROJECT_NAME}_core STATIC ${NE_CORE_SOURCES})
target_sources(${PROJECT_NAME}_core PRIVATE src/core/common/covariance.cpp src/core/common/eigenvalues.cpp
  src/core/common/number_format.cpp)
set_target_properties(${PROJECT_NAME}_core PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_include_directories(${PROJECT_NAME}_core PUBLIC include ${EIGEN3_INCLUDE_DIRS} PRIVATE src/core)
target_include_directories(${PROJECT_NAME}_core SYSTEM PRIVATE ${GeographicLib_INCLUDE_DIR} ${BZIP2_INCLUDE_DIR}
  ${LZ4_INCLUDE_DIR})
target_link_libraries(${PROJECT_NAME}_core PUBLIC ${YAML_CPP_LIBRARIES} ${GeographicLib_LIBRARY} Threads::Threads
  ${BZIP2_LIBRARIES} ${LZ4_LIBRARY} PRIVATE nlohmann_json::nlohmann_json)
# The papers' model files (cmake/embedded_models.cmake), compiled on their own.
target_sources(${PROJECT_NAME}_core PRIVATE ${NE_EMBEDDED_MODELS_SOURCE})
set_source_files_properties(${NE_EMBEDDED_MODELS_SOURCE} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)

# The Python package in build/python: the module next to a copy of the package's Python files.
set(_ne_python_dir ${CMAKE_BINARY_DIR}/python/networked_estimation)
configure_file(src/networked_estimation/__init__.py ${_ne_python_dir}/__init__.py COPYONLY)
add_library(${PROJECT_NAME}_python MODULE
  src/python/analysis.cpp
  src/python/estimators.cpp
  src/python/module.cpp
  src/python/montecarlo.cpp
)
set_target_properties(${PROJECT_NAME}_python PROPERTIES OUTPUT_NAME _core PREFIX "" SUFFIX ".so"
  CXX_VISIBILITY_PRESET hidden LIBRARY_OUTPUT_DIRECTORY ${_ne_python_dir})
target_include_directories(${PROJECT_NAME}_python PRIVATE src/core)
target_link_libraries(${PROJECT_NAME}_python PRIVATE pybind11::module ${PROJECT_NAME}_core)

if(NE_BUILD_TOOLS)
  foreach(tool simulate replay score montecarlo analyze make_model fit_link)
    add_executable(${tool} src/tools/${tool}.cpp)
    target_link_libraries(${tool} ${PROJECT_NAME}_core)
  endforeach()
  install(TARGETS simulate replay score montecarlo analyze make_model fit_link RUNTIME DESTINATION bin)
  install(PROGRAMS scripts/plot_montecarlo.py scripts/plot_link.py DESTINATION bin)
endif()

# The same unity batches as the catkin build (CMakeLists.txt, docs/architecture.md "Build time").
if(NOT CMAKE_VERSION VERSION_LESS 3.16)
  set_target_properties(${PROJECT_NAME}_core PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 10)
  set_source_files_properties(src/core/estimators/rseio.cpp src/core/estimators/aoe.cpp src/core/estimators/kalman.cpp
    PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
  set_target_properties(${PROJECT_NAME}_python PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 6)
endif()

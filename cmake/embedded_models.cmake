# The model files the papers' experiments run (src/core/experiments/paper_models.cpp), compiled into
# the core: the text of each config/models/<name>.yaml, read here, goes into a generated source that
# paper_models.cpp parses with the model parser. config/models stays the one source of the numbers,
# and the tools and the Python module need no path to the source tree at run time. Editing one of
# the files re-runs CMake (CMAKE_CONFIGURE_DEPENDS), which regenerates the source.
set(NE_EMBEDDED_MODELS aoe_example zhou_example)
set(NE_EMBEDDED_MODEL_ENTRIES "")
foreach(_ne_model ${NE_EMBEDDED_MODELS})
  set(_ne_model_file ${PROJECT_SOURCE_DIR}/config/models/${_ne_model}.yaml)
  file(READ ${_ne_model_file} _ne_model_text)
  if(_ne_model_text MATCHES "\\)ne_yaml\"")
    message(FATAL_ERROR "${_ne_model_file}: holds the text )ne_yaml\" that ends the embedded string")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_ne_model_file})
  string(APPEND NE_EMBEDDED_MODEL_ENTRIES
    "    {\"${_ne_model}\", \"config/models/${_ne_model}.yaml\", R\"ne_yaml(${_ne_model_text})ne_yaml\"},\n")
endforeach()
set(NE_EMBEDDED_MODELS_SOURCE ${CMAKE_CURRENT_BINARY_DIR}/generated/embedded_models.cpp)
configure_file(${PROJECT_SOURCE_DIR}/cmake/embedded_models.cpp.in ${NE_EMBEDDED_MODELS_SOURCE} @ONLY)

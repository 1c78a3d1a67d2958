# Writes OUTPUT: a C++ file holding every file of SHADERS as a raw string literal, looked up
# by file name through splitray::gl::shader_source().
string(REPLACE "|" ";" SHADERS "${SHADERS}")
set(body "// Generated from src/splitray/render_gl/shaders by embed_shaders.cmake; do not edit.\n#include <string>\n#include <string_view>\n#include \"splitray/render_gl/shaders.hpp\"\n#include \"splitray/core/errors.hpp\"\nnamespace splitray::gl {\nstd::string_view shader_source(std::string_view name) {\n")
foreach(file ${SHADERS})
  get_filename_component(name ${file} NAME)
  file(READ ${file} text)
  string(APPEND body "  if (name == \"${name}\") return R\"glsl(${text})glsl\";\n")
endforeach()
string(APPEND body "  throw Error(std::string(name), \"no such embedded shader\");\n}\n}  // namespace splitray::gl\n")
file(WRITE ${OUTPUT}.tmp "${body}")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)

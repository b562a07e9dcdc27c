# Per-module include paths: a library exports only its own folder, so a source
# can include a module's headers only when its target links that module
# (directly or through a PUBLIC dependency); an include of a module above it
# fails to compile. Each module gets a folder in the build tree holding one
# symbolic link named after it (module-include/<name>/<name> -> the sources),
# and that folder is the library's public include path: `#include "nn/unet_gpu.h"`
# from a target that links icube_nn, `#include "kernels/nn/conv3d.h"` from one
# that links icube_kernels.
function(icube_module_include target name source_dir)
  set(root ${CMAKE_BINARY_DIR}/module-include/${name})
  file(MAKE_DIRECTORY ${root})
  file(CREATE_LINK ${source_dir} ${root}/${name} SYMBOLIC)
  target_include_directories(${target} PUBLIC ${root})
endfunction()

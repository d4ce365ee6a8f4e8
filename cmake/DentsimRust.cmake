# Builds the Rust core (crates/ffi, a staticlib with the cxx bridge and OpenVDB glue) with cargo
# and imports it as `dentsim::ffi`. There is no Corrosion package on Debian 12; this is enough.
find_program(CARGO_EXECUTABLE cargo HINTS "$ENV{HOME}/.cargo/bin" REQUIRED)

get_filename_component(DENTSIM_SOURCE_ROOT "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
if (DEFINED ENV{CARGO_TARGET_DIR})
  set(DENTSIM_CARGO_TARGET_DIR "$ENV{CARGO_TARGET_DIR}")
else ()
  set(DENTSIM_CARGO_TARGET_DIR "${DENTSIM_SOURCE_ROOT}/target")
endif ()
set(DENTSIM_FFI_LIB "${DENTSIM_CARGO_TARGET_DIR}/release/libdentsim_ffi.a")

# Always run cargo: it knows whether anything changed, CMake does not. The whole workspace, as
# scripts/setup.sh builds it: `-p dentsim-ffi` alone resolves other features (no bench crate, so
# no `peer` in dentsim-vdb) and rebuilt the core and its C++ a second time.
add_custom_target(dentsim_ffi_cargo
  COMMAND "${CARGO_EXECUTABLE}" build --release --workspace
  WORKING_DIRECTORY "${DENTSIM_SOURCE_ROOT}"
  BYPRODUCTS "${DENTSIM_FFI_LIB}"
  COMMENT "cargo build --release --workspace"
  USES_TERMINAL)

find_package(Threads REQUIRED)
add_library(dentsim_ffi STATIC IMPORTED GLOBAL)
add_library(dentsim::ffi ALIAS dentsim_ffi)
# The generated bridge header and rust/cxx.h live under target/cxxbridge.
file(MAKE_DIRECTORY "${DENTSIM_CARGO_TARGET_DIR}/cxxbridge")
set_target_properties(dentsim_ffi PROPERTIES
  IMPORTED_LOCATION "${DENTSIM_FFI_LIB}"
  INTERFACE_INCLUDE_DIRECTORIES "${DENTSIM_CARGO_TARGET_DIR}/cxxbridge"
  # From `cargo rustc -p dentsim-ffi --crate-type staticlib -- --print native-static-libs`.
  INTERFACE_LINK_LIBRARIES "openvdb;tbb;Imath-3_1;hidapi-hidraw;Threads::Threads;${CMAKE_DL_LIBS};m;rt;util")
add_dependencies(dentsim_ffi dentsim_ffi_cargo)

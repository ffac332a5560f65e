# Locate (or obtain) the LAMMPS that HARDSPHERE_GPU is built against.
#
# Results:
#   target hsgpu::lammps     include path of LAMMPS's src/ headers, the LAMMPS library and
#                            its public compile definitions
#   HSGPU_LAMMPS_VERSION     LAMMPS release date as a number, e.g. 20250204 (from version.h)
#   LAMMPS_SOURCE_DIR        LAMMPS's src/ directory
#   LAMMPS_BINARY            the lmp executable (used by example tests), if known
#
# Ways to name a LAMMPS:
#   -D LAMMPS_ROOT=<prefix>          an installed LAMMPS (lib/cmake/LAMMPS) plus
#   -D LAMMPS_SOURCE_DIR=<src dir>   the src/ tree it was built from (for the headers), or
#   -D LAMMPS_SOURCE_DIR=<src dir> -D LAMMPS_LIBRARY=<liblammps.so> for a plain build tree.
# Without LAMMPS_SOURCE_DIR, tools/get_lammps.sh builds LAMMPS ${HSGPU_LAMMPS} into a cache.

set(HSGPU_LAMMPS "2025" CACHE STRING "LAMMPS to obtain when none is named: 2025 or 2021")
set_property(CACHE HSGPU_LAMMPS PROPERTY STRINGS 2025 2021)
set(HSGPU_LAMMPS_CACHE "" CACHE PATH "Where obtained LAMMPS builds are cached (default ~/.cache/hardsphere_gpu)")

# A LAMMPS obtained here is re-obtained when HSGPU_LAMMPS changes; one the user named is kept.
if(HSGPU_OBTAINED_LAMMPS AND NOT HSGPU_OBTAINED_LAMMPS STREQUAL HSGPU_LAMMPS)
  unset(LAMMPS_SOURCE_DIR CACHE)
  unset(LAMMPS_ROOT CACHE)
  unset(LAMMPS_BINARY CACHE)
  unset(LAMMPS_DIR CACHE)
endif()
if(NOT LAMMPS_SOURCE_DIR)
  set(_args ${HSGPU_LAMMPS})
  if(HSGPU_LAMMPS_CACHE)
    list(APPEND _args ${HSGPU_LAMMPS_CACHE})
  endif()
  message(STATUS "HARDSPHERE_GPU: obtaining LAMMPS ${HSGPU_LAMMPS} (cached after the first build)")
  execute_process(COMMAND bash ${CMAKE_CURRENT_LIST_DIR}/../tools/get_lammps.sh ${_args}
                  OUTPUT_VARIABLE _out RESULT_VARIABLE _rc OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "tools/get_lammps.sh ${HSGPU_LAMMPS} failed (exit ${_rc})")
  endif()
  string(REGEX REPLACE ".*\n" "" _prefix "${_out}")
  set(LAMMPS_ROOT "${_prefix}" CACHE PATH "Installed LAMMPS prefix" FORCE)
  file(READ "${_prefix}/LAMMPS_SOURCE_DIR" _src)
  string(STRIP "${_src}" _src)
  set(LAMMPS_SOURCE_DIR "${_src}" CACHE PATH "LAMMPS src/ directory (headers)" FORCE)
  set(HSGPU_OBTAINED_LAMMPS "${HSGPU_LAMMPS}" CACHE INTERNAL "HSGPU_LAMMPS that LAMMPS_ROOT was obtained for")
endif()

if(NOT EXISTS "${LAMMPS_SOURCE_DIR}/lammps.h")
  message(FATAL_ERROR "LAMMPS_SOURCE_DIR=${LAMMPS_SOURCE_DIR} holds no lammps.h: name LAMMPS's src/ directory")
endif()

# LAMMPS has no numeric version macro: derive one from version.h ("4 Feb 2025" -> 20250204).
file(STRINGS "${LAMMPS_SOURCE_DIR}/version.h" _vline REGEX "define LAMMPS_VERSION")
string(REGEX MATCH "\"([0-9]+) ([A-Za-z]+) ([0-9]+)\"" _m "${_vline}")
if(NOT _m)
  message(FATAL_ERROR "Cannot read the LAMMPS version from ${LAMMPS_SOURCE_DIR}/version.h")
endif()
set(_day ${CMAKE_MATCH_1})
set(_year ${CMAKE_MATCH_3})
set(_months Jan Feb Mar Apr May Jun Jul Aug Sep Oct Nov Dec)
list(FIND _months "${CMAKE_MATCH_2}" _mi)
math(EXPR _mon "${_mi} + 1")
if(_mon LESS 10)
  set(_mon "0${_mon}")
endif()
if(_day LESS 10)
  set(_day "0${_day}")
endif()
set(HSGPU_LAMMPS_VERSION "${_year}${_mon}${_day}")
if(HSGPU_LAMMPS_VERSION LESS 20210929)
  message(FATAL_ERROR "LAMMPS ${HSGPU_LAMMPS_VERSION} is older than 29 Sep 2021, the oldest supported")
endif()

add_library(hsgpu_lammps INTERFACE)
add_library(hsgpu::lammps ALIAS hsgpu_lammps)
target_include_directories(hsgpu_lammps SYSTEM INTERFACE "${LAMMPS_SOURCE_DIR}")
target_compile_definitions(hsgpu_lammps INTERFACE HSGPU_LAMMPS_VERSION=${HSGPU_LAMMPS_VERSION})

if(LAMMPS_ROOT)
  find_package(LAMMPS CONFIG REQUIRED PATHS "${LAMMPS_ROOT}" NO_DEFAULT_PATH)
  target_link_libraries(hsgpu_lammps INTERFACE LAMMPS::lammps)
  if(NOT LAMMPS_BINARY AND EXISTS "${LAMMPS_ROOT}/bin/lmp")
    set(LAMMPS_BINARY "${LAMMPS_ROOT}/bin/lmp" CACHE FILEPATH "LAMMPS executable" FORCE)
  endif()
elseif(LAMMPS_LIBRARY)
  set(LAMMPS_DEFINITIONS "LAMMPS_SMALLBIG;LAMMPS_EXCEPTIONS" CACHE STRING
      "Public compile definitions LAMMPS was built with")
  target_link_libraries(hsgpu_lammps INTERFACE "${LAMMPS_LIBRARY}")
  target_compile_definitions(hsgpu_lammps INTERFACE ${LAMMPS_DEFINITIONS})
else()
  message(FATAL_ERROR "With LAMMPS_SOURCE_DIR also name LAMMPS_ROOT (an installed LAMMPS) "
                      "or LAMMPS_LIBRARY (its liblammps.so)")
endif()
set(LAMMPS_BINARY "${LAMMPS_BINARY}" CACHE FILEPATH "LAMMPS executable for the example tests")

# Links gRPC, Protobuf, Abseil, Draco and their own dependencies from Debian's static archives
# (lib*.a, shipped beside the shared libraries by the same -dev packages) instead of their
# shared objects.
#
# Why: a process linked against the shared objects loads ~60 of them (Abseil alone is ~40) and
# spends its start resolving their symbols, ~40% of `meshsmooth --version`'s CPU time in the
# dynamic loader's symbol lookup (figures in docs/decisions.md, "Speed"). The C and C++
# runtimes and OpenMP stay shared.
#
# meshsmooth_use_static_archives(TARGET...) rewrites, for every imported target reachable from
# the given ones, an IMPORTED_LOCATION that names lib<name>.so* into lib<name>.a when that
# file exists, and a bare library name in their INTERFACE_LINK_LIBRARIES (gRPC's re2) into its
# archive's path. Imported targets are global, so every program of the build links the same
# way: there is one copy of each library in a process (Protobuf's descriptor pool would not
# survive two).

set(_meshsmooth_keep_shared dl m rt pthread c stdc++ gcc_s gomp)

function(_meshsmooth_static_location path out)
  set(${out} "" PARENT_SCOPE)
  if(NOT path MATCHES "^(.*/lib[^/]+)\\.so(\\.[0-9.]+)?$")
    return()
  endif()
  set(candidate "${CMAKE_MATCH_1}.a")
  if(EXISTS "${candidate}")
    set(${out} "${candidate}" PARENT_SCOPE)
  endif()
endfunction()

function(_meshsmooth_make_static target)
  get_property(done GLOBAL PROPERTY _meshsmooth_static_done)
  if(target IN_LIST done OR NOT TARGET ${target})
    return()
  endif()
  set_property(GLOBAL APPEND PROPERTY _meshsmooth_static_done ${target})
  get_target_property(imported ${target} IMPORTED)
  if(NOT imported)
    return()
  endif()
  get_target_property(aliased ${target} ALIASED_TARGET)
  if(aliased)
    _meshsmooth_make_static(${aliased})
    return()
  endif()
  get_target_property(type ${target} TYPE)
  if(NOT type STREQUAL "INTERFACE_LIBRARY")
    foreach(suffix "" _NONE _RELEASE _RELWITHDEBINFO _DEBUG _MINSIZEREL _NOCONFIG)
      get_target_property(location ${target} IMPORTED_LOCATION${suffix})
      if(location)
        _meshsmooth_static_location("${location}" archive)
        if(archive)
          set_target_properties(${target} PROPERTIES IMPORTED_LOCATION${suffix} "${archive}"
                                                     IMPORTED_NO_SONAME TRUE)
        endif()
      endif()
    endforeach()
  endif()
  get_target_property(links ${target} INTERFACE_LINK_LIBRARIES)
  if(NOT links)
    return()
  endif()
  set(rewritten "")
  foreach(item IN LISTS links)
    if(TARGET ${item})
      _meshsmooth_make_static(${item})
    elseif(item MATCHES "^-l?([A-Za-z0-9_+-]+)$" AND NOT CMAKE_MATCH_1 IN_LIST _meshsmooth_keep_shared)
      find_file(_archive lib${CMAKE_MATCH_1}.a PATHS ${CMAKE_LIBRARY_ARCHITECTURE_DIRS}
                /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE} NO_DEFAULT_PATH NO_CACHE)
      if(_archive)
        set(item "${_archive}")
      endif()
      unset(_archive)
    endif()
    list(APPEND rewritten "${item}")
  endforeach()
  set_target_properties(${target} PROPERTIES INTERFACE_LINK_LIBRARIES "${rewritten}")
endfunction()

function(meshsmooth_use_static_archives)
  foreach(target IN LISTS ARGN)
    _meshsmooth_make_static(${target})
  endforeach()
endfunction()

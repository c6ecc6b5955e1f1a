# Links gRPC, Protobuf, Abseil, Draco and their own dependencies from Debian's static archives
# (lib*.a, shipped beside the shared libraries by the same -dev packages) instead of their
# shared objects.
#
# Why: a process linked against the shared objects loads ~60 of them (Abseil alone is ~40) and
# spends its start resolving their symbols, ~40% of `meshsmooth --version`'s CPU time in the
# dynamic loader's symbol lookup (figures in docs/decisions.md, "Speed"). The C and C++
# runtimes and OpenMP stay shared.
#
# meshsmooth_use_static_archives(TARGET...) rewrites, for each imported target given (the root
# directory passes every one its find_package calls defined), an IMPORTED_LOCATION that names
# lib<name>.so* into lib<name>.a when that file exists, and a bare library name in its
# INTERFACE_LINK_LIBRARIES (gRPC's re2) into its archive's path. Imported targets are global, so
# every program of the build links the same way: there is one copy of each library in a process
# (Protobuf's descriptor pool would not survive two).

set(_meshsmooth_keep_shared dl m rt pthread c stdc++ gcc_s gomp)

function(_meshsmooth_make_static target)
  get_target_property(type ${target} TYPE)
  if(NOT type STREQUAL "INTERFACE_LIBRARY")
    foreach(suffix "" _NONE _RELEASE _RELWITHDEBINFO _DEBUG _MINSIZEREL _NOCONFIG)
      get_target_property(location ${target} IMPORTED_LOCATION${suffix})
      if(location MATCHES "^(.*/lib[^/]+)\\.so(\\.[0-9.]+)?$")
        set(archive "${CMAKE_MATCH_1}.a")
        if(EXISTS "${archive}")
          set_target_properties(${target} PROPERTIES IMPORTED_LOCATION${suffix} "${archive}" IMPORTED_NO_SONAME TRUE)
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
    if(NOT TARGET ${item} AND item MATCHES "^-l?([A-Za-z0-9_+-]+)$"
       AND NOT CMAKE_MATCH_1 IN_LIST _meshsmooth_keep_shared)
      find_file(_archive lib${CMAKE_MATCH_1}.a PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE} NO_DEFAULT_PATH
                NO_CACHE)
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
    get_target_property(imported ${target} IMPORTED)
    get_target_property(aliased ${target} ALIASED_TARGET)
    if(imported AND NOT aliased)
      _meshsmooth_make_static(${target})
    endif()
  endforeach()
endfunction()

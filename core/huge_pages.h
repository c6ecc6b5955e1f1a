// Large buffers backed by transparent huge pages, for the whole process.
//
// On the virtual machines meshsmooth runs on, a first touch of a 4 KiB page costs ~10 us (a
// fresh 16 MB vector of 655k positions: ~40 ms before any work), and a job allocates tens of
// such buffers: Draco's decode, the welded mesh, the topology, the flow's double buffer, the
// encoded result. Where the kernel gives transparent huge pages on request
// (/sys/kernel/mm/transparent_hugepage/enabled is "madvise"), glibc's malloc asks for them when
// the tunable glibc.malloc.hugetlb=1 is set, and the same faults cost ~50x less
// (docs/performance.md); with glibc.malloc.arena_max=1 the worker threads allocate from the
// main arena too, which measured 1.5-2x faster for a job's steps than their own arenas.
// Tunables are read when a program starts, so the binaries call this first thing in main().
#pragma once

namespace meshsmooth {

// Re-executes the program (same pid, same argv, same environment plus
// GLIBC_TUNABLES=...:glibc.malloc.hugetlb=1:glibc.malloc.arena_max=1) unless
// glibc.malloc.hugetlb is already set, the kernel's THP mode is not "madvise", the environment
// says MESHSMOOTH_HUGE_PAGES=0, or the build is sanitized. Call it before any thread exists.
// Returns when nothing was done or exec failed.
void UseHugePagesForLargeBuffers(char** argv);

}  // namespace meshsmooth

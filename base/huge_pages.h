// Large buffers backed by transparent huge pages, for the whole process.
//
// On the virtual machines meshsmooth runs on, a first touch of a 4 KiB page is slow enough that
// a fresh buffer costs more to fault in than the work done in it, and a job allocates tens of
// such buffers: Draco's decode, the welded mesh, the topology, the flow's double buffer, the
// encoded result. Where the kernel gives transparent huge pages on request
// (/sys/kernel/mm/transparent_hugepage/enabled is "madvise"), glibc's malloc asks for them when
// the tunable glibc.malloc.hugetlb=1 is set, and the same memory costs a small fraction of
// that; with glibc.malloc.arena_max=1 the worker threads allocate from the main arena too, where
// a job's steps run faster than in their own arenas (figures in docs/decisions.md, "Speed").
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

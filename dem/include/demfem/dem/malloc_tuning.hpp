// Process-wide malloc settings for programs that run the DEM engine (the demfem command, the
// benchmarks); the engine itself never changes them.
#pragma once

namespace demfem::dem {

// Keeps freed blocks of up to 32 MB in the heap for reuse, and up to 64 MB of free heap top
// (glibc: M_MMAP_THRESHOLD, M_TRIM_THRESHOLD; fixed values also stop glibc's own adjustment of
// them). Each neighbour rebuild allocates the new list's contact history (16 B per entry) and
// frees the old one: with glibc's defaults the block often came from fresh pages, and on this
// project's virtual machines a first touch costs ≈ 11 µs per 4 KB page — 1.0–1.7 ms of a 2.5 ms
// rebuild of 10⁴ disks, against ≈ 70 µs when the freed block is reused (bench/RESULTS.md).
// Larger blocks (the arrays of 10⁶–10⁷ particles) still come from and go
// back to the system. No effect outside glibc.
void keep_freed_memory_for_reuse();

} // namespace demfem::dem

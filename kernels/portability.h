// Work-arounds for OpenCL implementations that miscompile valid OpenCL C 1.2, each with its
// reason (measurements and reproducers: docs/portability.md).
#ifndef CLRENDER_PORTABILITY_H
#define CLRENDER_PORTABILITY_H

// Every kernel entry point is declared KERNEL. vec_type_hint (OpenCL C 1.2, 6.7.2) states that
// the kernel already computes in 4-wide vectors. Intel's CPU runtime (2026.2) then does not
// vectorise it across work-items ("implicit vectorisation"), which it gets wrong: in a vectorised
// kernel, a call to a function that is not inlined and takes or returns a float3 (by value, in a
// struct or through a pointer) reads wrong lanes. That made odd entries of the rough-lobe energy
// tables wrong and the ray-marching kernel read garbage (79 KB of private memory per work-item).
// Other implementations treat the attribute as a hint only.
#define KERNEL __kernel __attribute__((vec_type_hint(float4)))

// Asks for the cache line at P ahead of its use: where a packet's lanes each read memory that
// is likely not cached (a hit's triangle records, texels), asking for all lanes' lines first
// lets the misses overlap. clang's builtin where the kernel is compiled for the CPU itself
// (PoCL); nothing where it is compiled to SPIR (Intel's CPU runtime, Oclgrind) or for a GPU.
#if defined(__x86_64__) || defined(__aarch64__)
#define PREFETCH(P) __builtin_prefetch(P)
#else
#define PREFETCH(P) ((void)0)
#endif

#endif

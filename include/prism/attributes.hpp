// prism/attributes.hpp — the compiler attributes that prism's hot paths use,
// spelled once. Each expands to nothing on compilers that lack it, and each
// may be predefined by the user (say, empty, to see what it is worth).
#pragma once

// Inlines everything a function calls (a traversal loop, its leaf callback
// and the triangle test), so that per-ray constants fold into the loop.
#ifndef PRISM_FLATTEN
#if defined(__GNUC__) || defined(__clang__)
#define PRISM_FLATTEN [[gnu::flatten]]
#else
#define PRISM_FLATTEN
#endif
#endif

// Keeps a function out of its callers, whose own code then stays small.
#ifndef PRISM_NOINLINE
#if defined(__GNUC__) || defined(__clang__)
#define PRISM_NOINLINE [[gnu::noinline]]
#else
#define PRISM_NOINLINE
#endif
#endif

// Out of line and laid out away from the hot code: for a path that runs
// rarely (the compiler also takes its callers' branches to it as unlikely).
#ifndef PRISM_COLD
#if defined(__GNUC__) || defined(__clang__)
#define PRISM_COLD [[gnu::noinline, gnu::cold]]
#else
#define PRISM_COLD
#endif
#endif

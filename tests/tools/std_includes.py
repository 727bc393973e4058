#!/usr/bin/env python3
"""Every public header names the standard headers it uses.

The header check (tests/CMakeLists.txt) compiles each header alone: that
proves it includes the prism headers it needs, but proves little about the
standard ones, since one standard library header may include another (a
header using std::visit compiles without <variant> when, with one standard
library, <functional> brings it in). This check covers them: for each header
under include/prism/, the standard names it uses (std::vector, std::visit,
std::sqrt, ...) must be declared by a standard header it includes, directly
or through the prism headers it includes. The map below lists where the
standard declares each name (the C++20 standard's header synopses); names it
does not list are not checked.

Usage: std_includes.py INCLUDE_DIR   (prints each miss; exit 1 if any)
"""
import os
import re
import sys

# name -> the standard headers that declare it (any one suffices)
DECLARED_IN = {
    "vector": ["vector"], "array": ["array"], "string": ["string"], "string_view": ["string_view", "string"],
    "to_string": ["string"], "stoi": ["string"], "stod": ["string"], "getline": ["string"],
    "optional": ["optional"], "nullopt": ["optional"], "variant": ["variant"], "visit": ["variant"],
    "holds_alternative": ["variant"], "get_if": ["variant"], "monostate": ["variant"],
    "unique_ptr": ["memory"], "shared_ptr": ["memory"], "make_unique": ["memory"], "make_shared": ["memory"],
    "function": ["functional"], "hash": ["functional"],
    "map": ["map"], "multimap": ["map"], "set": ["set"], "unordered_map": ["unordered_map"],
    "unordered_set": ["unordered_set"], "deque": ["deque"], "queue": ["queue"], "priority_queue": ["queue"],
    "pair": ["utility"], "move": ["utility", "algorithm"], "forward": ["utility"], "swap": ["utility"],
    "exchange": ["utility"], "make_pair": ["utility"], "index_sequence": ["utility"],
    "make_index_sequence": ["utility"], "in_place_type": ["utility"],
    "tuple": ["tuple"], "tie": ["tuple"], "make_tuple": ["tuple"],
    "sort": ["algorithm"], "stable_sort": ["algorithm"], "nth_element": ["algorithm"], "partition": ["algorithm"],
    "min_element": ["algorithm"], "max_element": ["algorithm"], "clamp": ["algorithm"], "fill": ["algorithm"],
    "copy": ["algorithm"], "find": ["algorithm"], "find_if": ["algorithm"], "reverse": ["algorithm"],
    "lower_bound": ["algorithm"], "upper_bound": ["algorithm"], "all_of": ["algorithm"], "any_of": ["algorithm"],
    "none_of": ["algorithm"], "count_if": ["algorithm"], "remove_if": ["algorithm"], "unique": ["algorithm"],
    "transform": ["algorithm"], "equal": ["algorithm"],
    "accumulate": ["numeric"], "iota": ["numeric"], "partial_sum": ["numeric"], "inner_product": ["numeric"],
    "sqrt": ["cmath"], "exp": ["cmath"], "log": ["cmath"], "log2": ["cmath"], "pow": ["cmath"],
    "sin": ["cmath"], "cos": ["cmath"], "tan": ["cmath"], "atan2": ["cmath"], "acos": ["cmath"],
    "asin": ["cmath"], "atan": ["cmath"], "floor": ["cmath"], "ceil": ["cmath"], "isfinite": ["cmath"],
    "isnan": ["cmath"], "isinf": ["cmath"], "fma": ["cmath"], "ldexp": ["cmath"], "frexp": ["cmath"],
    "copysign": ["cmath"], "hypot": ["cmath"], "erf": ["cmath"], "erfc": ["cmath"], "lgamma": ["cmath"],
    "expm1": ["cmath"], "log1p": ["cmath"], "cbrt": ["cmath"], "round": ["cmath"], "lround": ["cmath"],
    "trunc": ["cmath"], "fmod": ["cmath"], "nextafter": ["cmath"], "signbit": ["cmath"], "exp2": ["cmath"],
    "numeric_limits": ["limits"],
    "thread": ["thread"], "mutex": ["mutex"], "lock_guard": ["mutex"], "unique_lock": ["mutex"],
    "scoped_lock": ["mutex"], "condition_variable": ["condition_variable"], "atomic": ["atomic"],
    "memory_order_relaxed": ["atomic"],
    "chrono": ["chrono"], "cout": ["iostream"], "cerr": ["iostream"], "clog": ["iostream"],
    "ostream": ["ostream", "iostream"], "istream": ["istream", "iostream"],
    "ifstream": ["fstream"], "ofstream": ["fstream"], "ostringstream": ["sstream"],
    "istringstream": ["sstream"], "stringstream": ["sstream"],
    "filesystem": ["filesystem"], "span": ["span"], "bit_cast": ["bit"], "popcount": ["bit"],
    "countl_zero": ["bit"], "countr_zero": ["bit"], "bit_width": ["bit"],
    "memcpy": ["cstring"], "memset": ["cstring"], "memcmp": ["cstring"], "strlen": ["cstring"],
    "strcmp": ["cstring"], "strncmp": ["cstring"],
    "size_t": ["cstddef", "cstdio", "cstdlib", "cstring"], "ptrdiff_t": ["cstddef"], "byte": ["cstddef"],
    "uint8_t": ["cstdint"], "uint16_t": ["cstdint"], "uint32_t": ["cstdint"], "uint64_t": ["cstdint"],
    "int8_t": ["cstdint"], "int16_t": ["cstdint"], "int32_t": ["cstdint"], "int64_t": ["cstdint"],
    "uintptr_t": ["cstdint"],
    "printf": ["cstdio"], "fprintf": ["cstdio"], "snprintf": ["cstdio"], "fopen": ["cstdio"],
    "fclose": ["cstdio"], "fread": ["cstdio"], "fwrite": ["cstdio"], "FILE": ["cstdio"], "puts": ["cstdio"],
    "fflush": ["cstdio"],
    "abort": ["cstdlib"], "exit": ["cstdlib"], "getenv": ["cstdlib"], "strtod": ["cstdlib"], "strtol": ["cstdlib"],
    "malloc": ["cstdlib"], "free": ["cstdlib"],
    "exception": ["exception"], "exception_ptr": ["exception"], "current_exception": ["exception"],
    "rethrow_exception": ["exception"], "runtime_error": ["stdexcept"], "invalid_argument": ["stdexcept"],
    "out_of_range": ["stdexcept"], "logic_error": ["stdexcept"], "bad_alloc": ["new"],
    "initializer_list": ["initializer_list"],
    "is_same_v": ["type_traits"], "enable_if_t": ["type_traits"], "decay_t": ["type_traits"],
    "remove_cvref_t": ["type_traits"], "conditional_t": ["type_traits"], "is_floating_point_v": ["type_traits"],
    "is_integral_v": ["type_traits"], "integral_constant": ["type_traits"], "true_type": ["type_traits"],
    "false_type": ["type_traits"], "invoke_result_t": ["type_traits"],
    "same_as": ["concepts"], "convertible_to": ["concepts"], "floating_point": ["concepts"],
    "integral": ["concepts"], "invocable": ["concepts"], "derived_from": ["concepts"],
    "error_code": ["system_error"], "random_device": ["random"], "mt19937": ["random"],
    "mt19937_64": ["random"], "uniform_real_distribution": ["random"],
    "back_inserter": ["iterator"], "distance": ["iterator"], "next": ["iterator"], "prev": ["iterator"],
    "begin": ["iterator", "array", "vector", "string", "span"], "end": ["iterator", "array", "vector", "string", "span"],
    "data": ["iterator", "array", "vector", "string", "span"], "size": ["iterator", "array", "vector", "string", "span"],
    "setw": ["iomanip"], "setprecision": ["iomanip"], "quoted": ["iomanip"],
}
# Standard headers that the standard says include others (C++20 [iostream.syn],
# [string.syn] and friends): including the first is including the rest.
IMPLIES = {
    "iostream": ["ostream", "istream"], "fstream": ["ostream", "istream"], "sstream": ["ostream", "istream", "string"],
    "string": ["string_view", "initializer_list"], "vector": ["initializer_list"], "map": ["initializer_list"],
    "set": ["initializer_list"], "unordered_map": ["initializer_list"], "array": [], "utility": ["initializer_list"],
    "atomic": [], "random": ["initializer_list"], "filesystem": ["string"], "system_error": [],
    "cstdio": [], "cstdlib": [],
}

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)
USE = re.compile(r'\bstd::(?:chrono::|filesystem::|numbers::)?([A-Za-z_][A-Za-z_0-9]*)')
COMMENT = re.compile(r'//[^\n]*|/\*.*?\*/', re.S)
STRING = re.compile(r'"(?:\\.|[^"\\\n])*"')


def main(include_dir):
    headers = {}
    for root, _, files in os.walk(os.path.join(include_dir, "prism")):
        for f in files:
            if f.endswith(".hpp"):
                path = os.path.join(root, f)
                headers[os.path.relpath(path, include_dir)] = open(path, encoding="utf-8").read()
    direct = {}
    for name, text in headers.items():
        std, ours = set(), set()
        for kind, inc in INCLUDE.findall(text):
            if inc in headers:
                ours.add(inc)
            elif kind == "<" and "/" not in inc and "." not in inc:
                std.add(inc)
        direct[name] = (std, ours)

    memo = {}

    def reachable(name, seen=()):
        if name in memo:
            return memo[name]
        std, ours = direct[name]
        out = set(std)
        for o in ours:
            if o not in seen:
                out |= reachable(o, seen + (name,))
        for s in list(out):
            out |= set(IMPLIES.get(s, []))
        memo[name] = out
        return out

    misses = 0
    for name in sorted(headers):
        code = STRING.sub('""', COMMENT.sub("", headers[name]))
        have = reachable(name)
        for sym in sorted(set(USE.findall(code))):
            wanted = DECLARED_IN.get(sym)
            if wanted and not any(w in have for w in wanted):
                print(f"{name}: uses std::{sym} but includes none of <{'>, <'.join(wanted)}> (directly or through prism headers)")
                misses += 1
    print(f"std_includes: {len(headers)} headers, {misses} missing standard includes")
    return 1 if misses else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "include"))

// Little-endian u32 framing over stdin/stdout for the co-simulation binaries.
#pragma once
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>

namespace io {

// The word stream's FILE: stdout until init() moves it.
inline FILE*& words_out() {
    static FILE* f = stdout;
    return f;
}

// Moves the word stream to a descriptor of its own and points stdout at stderr, so that
// Verilator's messages (an assertion failure, $display) go to stderr, not into the pipe.
inline void init() {
    int fd = dup(1);
    if (fd < 0) std::exit(3);
    FILE* f = fdopen(fd, "wb");
    if (f == nullptr || dup2(2, 1) < 0) std::exit(3);
    words_out() = f;
}

// Reads exactly n bytes; returns false at end of input.
inline bool read_all(void* buf, size_t n) {
    uint8_t* p = static_cast<uint8_t*>(buf);
    while (n > 0) {
        ssize_t r = ::read(0, p, n);
        if (r <= 0) return false;
        p += r;
        n -= static_cast<size_t>(r);
    }
    return true;
}

inline bool read_u32(uint32_t& v) {
    uint8_t b[4];
    if (!read_all(b, 4)) return false;
    v = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
    return true;
}

inline void write_u32(uint32_t v) {
    uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    if (fwrite(b, 1, 4, words_out()) != 4) std::exit(3);
}

inline void flush() {
    if (fflush(words_out()) != 0) std::exit(3);
}

}  // namespace io

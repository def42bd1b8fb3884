// Unit co-simulation of the datapath blocks (rtl/tb/gridrt_units_top.sv), driven from Rust
// (gridrt-rtl: units.rs). Protocol over stdin/stdout, u32 little-endian:
//   request  = unit, count, [ray header], count x vector
//   response = count x result
// unit 1 f32_addsub: (a, b, sub) -> (y)      unit 2 f32_mul: (a, b) -> (y)
// unit 3 f32_to_fixed: (x, k) -> (q_lo, q_hi, huge)
// unit 4 isect_pipe: header (o0 lo hi, o1 lo hi, o2 lo hi, kz, sx, sy, dz_neg, dz_abs, texp,
//        ray_overflow), vector = 9 record words -> (kind, t)
// unit 0 ends the process.
#include <vector>
#include "Vgridrt_units_top.h"
#include "io.h"
#include "verilated.h"

static Vgridrt_units_top* top;

static void tick() {
    top->clk_i = 0;
    top->eval();
    top->clk_i = 1;
    top->eval();
}

static uint64_t sext(uint64_t v, int bits) {
    uint64_t m = 1ull << (bits - 1);
    v &= (bits == 64) ? ~0ull : ((1ull << bits) - 1);
    return (v ^ m) - m;
}

int main(int argc, char** argv) {
    Verilated::commandArgs(argc, argv);
    io::init();
    top = new Vgridrt_units_top;
    top->clk_i = 0;
    top->eval();
    for (;;) {
        uint32_t unit, count;
        if (!io::read_u32(unit) || unit == 0) break;
        if (!io::read_u32(count)) break;
        int in_words = unit == 1 ? 3 : unit == 4 ? 9 : 2;
        int hdr_words = unit == 4 ? 13 : 0;
        std::vector<uint32_t> hdr(hdr_words), in(size_t(count) * in_words);
        for (auto& w : hdr) if (!io::read_u32(w)) return 1;
        for (auto& w : in) if (!io::read_u32(w)) return 1;
        if (unit == 4) {
            top->is_o0_i = (uint64_t(hdr[1]) << 32 | hdr[0]) & ((1ull << 34) - 1);
            top->is_o1_i = (uint64_t(hdr[3]) << 32 | hdr[2]) & ((1ull << 34) - 1);
            top->is_o2_i = (uint64_t(hdr[5]) << 32 | hdr[4]) & ((1ull << 34) - 1);
            top->is_kz_i = hdr[6];
            top->is_sx_i = hdr[7] & ((1u << 25) - 1);
            top->is_sy_i = hdr[8] & ((1u << 25) - 1);
            top->is_dz_neg_i = hdr[9];
            top->is_dz_abs_i = hdr[10];
            top->is_texp_i = hdr[11] & 0x3FF;
            top->is_ray_overflow_i = hdr[12];
        }
        uint32_t sent = 0, got = 0;
        while (got < count) {
            bool feed = sent < count;
            const uint32_t* v = feed ? &in[size_t(sent) * in_words] : nullptr;
            top->add_valid_i = feed && unit == 1;
            top->mul_valid_i = feed && unit == 2;
            top->is_valid_i = feed && unit == 4;
            top->fx_valid_i = feed && unit == 3;
            if (feed) {
                if (unit == 1) { top->add_a_i = v[0]; top->add_b_i = v[1]; top->add_sub_i = v[2] & 1; }
                if (unit == 2) { top->mul_a_i = v[0]; top->mul_b_i = v[1]; }
                if (unit == 3) { top->fx_x_i = v[0]; top->fx_k_i = v[1] & 0x3FF; }
                if (unit == 4) for (int i = 0; i < 9; i++) top->is_rec_i[i] = v[i];
            }
            tick();
            if (unit == 3 && top->fx_out_valid_o) {
                uint64_t q = sext(top->fx_q_o, 55);
                io::write_u32(uint32_t(q));
                io::write_u32(uint32_t(q >> 32));
                io::write_u32(top->fx_huge_o);
                got++;
            }
            if (unit == 1 && top->add_out_valid_o) { io::write_u32(top->add_y_o); got++; }
            if (unit == 2 && top->mul_out_valid_o) { io::write_u32(top->mul_y_o); got++; }
            if (unit == 4 && top->is_out_valid_o) { io::write_u32(top->is_kind_o); io::write_u32(top->is_t_o); got++; }
            if (feed) sent++;
        }
        // Drain so the next batch starts from an empty pipeline.
        top->add_valid_i = top->mul_valid_i = top->is_valid_i = top->fx_valid_i = 0;
        for (int i = 0; i < 64; i++) tick();
        io::flush();
    }
    top->final();
    delete top;
    return 0;
}

// Unit co-simulation of the datapath blocks (rtl/tb/gridrt_units_top.sv), driven from Rust
// (gridrt-rtl: units.rs). Protocol over stdin/stdout, u32 little-endian:
//   request  = unit, count, [ray header], count x vector
//   response = count x result
// unit 1 f32_addsub: (a, b, sub) -> (y)      unit 2 f32_mul: (a, b) -> (y)
// unit 3 f32_to_fixed: (x, k) -> (q_lo, q_hi, huge)
// unit 4 isect_pipe: header (o0 lo hi, o1 lo hi, o2 lo hi, kz, sx, sy, dz_neg, dz_abs, texp,
//        ray_overflow), vector = 9 record words -> (kind, t)
// unit 5 cfu_f32: header (seed, gap percent, stall percent), vector = (function_id, rs1, rs2)
//        -> (rd, latency: the clock edges from the command's handshake to the first edge
//        with rsp_valid high, the earliest possible response handshake); after them two
//        more words: the command and the response handshakes seen (both must equal count)
// unit 0 ends the process.
#include <cstdlib>
#include <random>
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

// The CFU as the CPU drives it, under random back-pressure: before each command cmd_valid
// stays low for a random gap (gap percent: the chance of one more idle cycle), and once
// offered the command is held until cmd_ready; rsp_ready is low in stall percent of the
// cycles. Handshakes are sampled before the clock edge (cmd_ready_o and rsp_valid_o depend
// only on registers). A response is written as it is taken; a response without an
// outstanding command is counted too, so the trailer shows drops and duplicates.
static void run_cfu(const std::vector<uint32_t>& hdr, const std::vector<uint32_t>& in, uint32_t count) {
    std::mt19937_64 rng(hdr[0]);
    const uint32_t gap = hdr[1], stall = hdr[2];
    auto chance = [&](uint32_t pct) { return uint32_t(rng() % 100) < pct; };
    // Reset, as LiteX's sys reset: synchronous, a few cycles, the CPU quiet.
    top->cfu_cmd_valid_i = 0;
    top->cfu_rsp_ready_i = 0;
    top->cfu_rst_i = 1;
    for (int i = 0; i < 3; i++) tick();
    top->cfu_rst_i = 0;
    uint64_t commands = 0, responses = 0, idle = 0, cycle = 0, fired_at = 0;
    uint32_t latency = 0;
    bool seen = false;
    uint32_t sent = 0;
    bool offered = false;
    // Run until every command is answered, then a while longer for stray responses.
    int after = 0;
    while (after < 64) {
        if (!offered && sent < count && !chance(gap)) offered = true;
        top->cfu_cmd_valid_i = offered;
        if (offered) {
            const uint32_t* v = &in[size_t(sent) * 3];
            top->cfu_cmd_function_id_i = v[0] & 0x3FF;
            top->cfu_cmd_inputs_0_i = v[1];
            top->cfu_cmd_inputs_1_i = v[2];
        } else {
            // Garbage on an idle bus must not matter.
            top->cfu_cmd_function_id_i = rng() & 0x3FF;
            top->cfu_cmd_inputs_0_i = uint32_t(rng());
            top->cfu_cmd_inputs_1_i = uint32_t(rng());
        }
        top->cfu_rsp_ready_i = !chance(stall);
        top->clk_i = 0;
        top->eval();
        bool cmd_fire = top->cfu_cmd_valid_i && top->cfu_cmd_ready_o;
        bool rsp_fire = top->cfu_rsp_valid_o && top->cfu_rsp_ready_i;
        uint32_t rd = top->cfu_rsp_outputs_0_o;
        if (top->cfu_rsp_valid_o && !seen) {
            latency = uint32_t(cycle - fired_at);
            seen = true;
        }
        top->clk_i = 1;
        top->eval();
        cycle++;
        if (cmd_fire) {
            commands++;
            fired_at = cycle - 1;
            sent++;
            offered = false;
        }
        if (rsp_fire) {
            // Only the first count responses are results; more are strays (counted).
            if (responses < count) {
                io::write_u32(rd);
                io::write_u32(latency);
            }
            responses++;
            seen = false;
        }
        idle = (cmd_fire || rsp_fire) ? 0 : idle + 1;
        if (idle > 100000) {
            std::fprintf(stderr, "units_main: cfu_f32 made no handshake in 100000 cycles (%llu commands, %llu responses of %u)\n",
                         (unsigned long long)commands, (unsigned long long)responses, count);
            std::exit(2);
        }
        if (sent == count && responses >= count) after++;
    }
    top->cfu_cmd_valid_i = 0;
    top->cfu_rsp_ready_i = 0;
    io::write_u32(uint32_t(commands));
    io::write_u32(uint32_t(responses));
}

int main(int argc, char** argv) {
    Verilated::commandArgs(argc, argv);
    io::init();
    top = new Vgridrt_units_top;
    top->clk_i = 0;
    top->cfu_rst_i = 1;
    top->eval();
    for (;;) {
        uint32_t unit, count;
        if (!io::read_u32(unit) || unit == 0) break;
        if (!io::read_u32(count)) break;
        int in_words = unit == 1 || unit == 5 ? 3 : unit == 4 ? 9 : 2;
        int hdr_words = unit == 4 ? 13 : unit == 5 ? 3 : 0;
        std::vector<uint32_t> hdr(hdr_words), in(size_t(count) * in_words);
        for (auto& w : hdr) if (!io::read_u32(w)) return 1;
        for (auto& w : in) if (!io::read_u32(w)) return 1;
        if (unit == 5) {
            run_cfu(hdr, in, count);
            io::flush();
            continue;
        }
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

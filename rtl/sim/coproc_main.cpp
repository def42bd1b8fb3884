// Co-simulation of the co-processor RTL (rtl/hdl/gridrt_coproc.sv) behind a pipe, driven by
// gridrt-rtl (rtl/src/sim.rs). Protocol over stdin/stdout, u32 little-endian:
//
//   1, data, control   queue one request word (FSL word; control = tlast)
//   2                  run until every queued word is consumed and the co-processor is idle;
//                      answer n, then n x (data, control): the reply words it produced
//   3                  answer the cycle counters: total lo, hi, busy lo, hi (busy = not idle)
//   4                  answer the PE-memory counters (a build with PE caches): stall cycles
//                      lo, hi (the co-processor stood still), external reads, writes (words)
//   0 / end of input   exit
//
// Options: --stall PERCENT delays offering the next request word (s_axis_tvalid; once offered
// it is held until taken, as AXI4-Stream requires) and drops m_axis_tready at random in that
// share of cycles (handshake stress; the results must not change), --seed N for that generator.
// --mem-latency N: the external memory behind the PE caches (mem_* ports) answers a request
// N cycles after it sees it (default 8; SDRAM on the board is slower and varies: the
// answers must not depend on it).
#include <algorithm>
#include <cstring>
#include <deque>
#include <random>
#include <string>
#include <vector>
#include "Vgridrt_coproc.h"
#include "io.h"
#include "verilated.h"

namespace {

// A drain that runs this many cycles without finishing means the RTL hangs.
constexpr uint64_t kWatchdogCycles = 200'000'000;

struct Word {
    uint32_t data;
    uint32_t control;
};

}  // namespace

int main(int argc, char** argv) {
    Verilated::commandArgs(argc, argv);
    io::init();
    int stall = 0;
    uint64_t seed = 1;
    int mem_latency = 8;
    for (int i = 1; i + 1 < argc; i++) {
        if (!std::strcmp(argv[i], "--stall")) stall = std::stoi(argv[i + 1]);
        if (!std::strcmp(argv[i], "--seed")) seed = std::stoull(argv[i + 1]);
        if (!std::strcmp(argv[i], "--mem-latency")) mem_latency = std::max(1, std::stoi(argv[i + 1]));
    }
    std::mt19937_64 rng(seed);
    auto* top = new Vgridrt_coproc;
    uint64_t cycles = 0, busy = 0;
    // The external memory: words by address, grown on demand; one request at a time.
    std::vector<uint32_t> mem;
    uint64_t mem_reads = 0, mem_writes = 0;
    int mem_wait = -1;  // cycles until the request in progress is answered; -1: none
    auto memory = [&]() {
        top->mem_ack_i = 0;
        if (mem_wait < 0 && top->mem_req_o) mem_wait = mem_latency - 1;
        if (mem_wait == 0) {
            uint32_t a = top->mem_addr_o;
            if (a >= mem.size()) mem.resize(size_t(a) + 1 + (size_t(a) >> 2), 0);
            if (top->mem_we_o) {
                mem[a] = top->mem_wdata_o;
                mem_writes++;
            } else {
                top->mem_rdata_i = mem[a];
                mem_reads++;
            }
            top->mem_ack_i = 1;
        }
        if (mem_wait >= 0) mem_wait--;
    };
    auto tick = [&]() {
        top->clk_i = 0;
        top->mem_ack_i = 0;
        top->eval();
        top->clk_i = 1;
        top->eval();
        cycles++;
    };
    top->rst_i = 1;
    top->s_axis_tvalid_i = 0;
    top->m_axis_tready_i = 0;
    for (int i = 0; i < 4; i++) tick();
    top->rst_i = 0;

    std::deque<Word> in;
    bool offered = false;  // the head word is on s_axis and not taken yet
    std::vector<Word> out;
    for (;;) {
        uint32_t cmd;
        if (!io::read_u32(cmd) || cmd == 0) break;
        if (cmd == 1) {
            Word w;
            if (!io::read_u32(w.data) || !io::read_u32(w.control)) break;
            in.push_back(w);
        } else if (cmd == 2) {
            uint64_t start = cycles;
            for (;;) {
                // Inputs for this cycle (set before the rising edge). AXI4-Stream: a word
                // once offered stays offered until it is taken (the RTL asserts it).
                bool offer = !in.empty() && (offered || !(stall && int(rng() % 100) < stall));
                offered = offer;
                bool take = !(stall && int(rng() % 100) < stall);
                top->s_axis_tvalid_i = offer;
                if (offer) {
                    top->s_axis_tdata_i = in.front().data;
                    top->s_axis_tlast_i = in.front().control & 1;
                }
                top->m_axis_tready_i = take;
                top->clk_i = 0;
                top->eval();
                memory();
                top->eval();
                bool accepted = offer && top->s_axis_tready_o;
                bool emitted = take && top->m_axis_tvalid_o;
                if (emitted) out.push_back({top->m_axis_tdata_o, top->m_axis_tlast_o});
                bool was_idle = top->idle_o;
                top->clk_i = 1;
                top->eval();
                cycles++;
                if (accepted) {
                    in.pop_front();
                    offered = false;
                }
                if (!was_idle) busy++;
                if (in.empty() && top->idle_o && !top->m_axis_tvalid_o) break;
                if (cycles - start > kWatchdogCycles) {
                    std::fprintf(stderr, "coproc sim: no progress after %llu cycles\n",
                                 (unsigned long long)(cycles - start));
                    return 2;
                }
            }
            top->s_axis_tvalid_i = 0;
            io::write_u32(uint32_t(out.size()));
            for (const Word& w : out) {
                io::write_u32(w.data);
                io::write_u32(w.control);
            }
            out.clear();
            io::flush();
        } else if (cmd == 3) {
            io::write_u32(uint32_t(cycles));
            io::write_u32(uint32_t(cycles >> 32));
            io::write_u32(uint32_t(busy));
            io::write_u32(uint32_t(busy >> 32));
            io::flush();
        } else if (cmd == 4) {
            uint64_t stalls = top->stall_cycles_o;
            io::write_u32(uint32_t(stalls));
            io::write_u32(uint32_t(stalls >> 32));
            io::write_u32(uint32_t(mem_reads));
            io::write_u32(uint32_t(mem_writes));
            io::flush();
        } else {
            std::fprintf(stderr, "coproc sim: unknown command %u\n", cmd);
            return 1;
        }
    }
    top->final();
    delete top;
    return 0;
}

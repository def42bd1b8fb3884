/* The Verilated model's side of LiteX's simulation core (the C ABI that LiteX's sim.c and
 * generated sim_init.cpp call: litex_sim_eval, litex_sim_init_cmdargs, litex_sim_init_tracer,
 * litex_sim_tracer_dump, litex_sim_got_finish, litex_sim_coverage_dump, sc_time_stamp),
 * written so that it also builds without Verilator's --trace.
 *
 * LiteX 2024.12's own veril.cpp calls the model's trace() unconditionally, so its simulation
 * is always Verilated with --trace, and a traced model pays for tracing on every cycle even
 * when nothing is dumped. Here tracing exists only when Verilator defines VM_TRACE
 * (`cargo xtask soc sim --trace`); its dump file is sim.vcd, as LiteX's.
 */
#include <stdint.h>

#include "Vsim.h"
#include "verilated.h"
#if VM_TRACE
#include "verilated_vcd_c.h"
#endif
#if VM_COVERAGE
#include "verilated_cov.h"
#endif

static uint64_t main_time = 0;

extern "C" void litex_sim_eval(void *vsim, uint64_t time_ps) {
  static_cast<Vsim *>(vsim)->eval();
  main_time = time_ps;
}

extern "C" void litex_sim_init_cmdargs(int argc, char *argv[]) { Verilated::commandArgs(argc, argv); }

#if VM_TRACE
static VerilatedVcdC *tfp = nullptr;
static uint64_t tfp_start, tfp_end;

extern "C" void litex_sim_init_tracer(void *vsim, long start, long end) {
  tfp_start = static_cast<uint64_t>(start);
  tfp_end = end >= 0 ? static_cast<uint64_t>(end) : UINT64_MAX;
  Verilated::traceEverOn(true);
  tfp = new VerilatedVcdC;
  static_cast<Vsim *>(vsim)->trace(tfp, 99);
  tfp->open("sim.vcd");
  tfp->set_time_unit("1ps");
  tfp->set_time_resolution("1ps");
}

extern "C" void litex_sim_tracer_dump() {
  if (tfp && tfp_start <= main_time && main_time <= tfp_end)
    tfp->dump(main_time);
}

extern "C" int litex_sim_got_finish() {
  int finished = Verilated::gotFinish();
  if (tfp) {
    tfp->flush();
    if (finished)
      tfp->close();
  }
  return finished;
}
#else
extern "C" void litex_sim_init_tracer(void *vsim, long start, long end) {
  (void)vsim;
  (void)start;
  (void)end;
}

extern "C" void litex_sim_tracer_dump() {}

extern "C" int litex_sim_got_finish() { return Verilated::gotFinish(); }
#endif

#if VM_COVERAGE
extern "C" void litex_sim_coverage_dump() { VerilatedCov::write("sim.cov"); }
#endif

double sc_time_stamp() { return static_cast<double>(main_time); }

"""The gridrt SoC: a LiteX SoC with a VexRiscv soft-core, a UART, a timer and the gridrt
ray-intersection co-processor (rtl/hdl/gridrt_coproc.sv) behind CSR FIFOs.

Modules, one concern each:

- ``coproc``: the co-processor core (``GridrtCoproc``) and its CSR FIFO bridge
  (``GridrtCoprocCSR``), LiteX style.
- ``soc``: ``GridrtSoC``, the SoC shared by every target (one memory map).
- ``sim``: the Verilator target (LiteX ``SimPlatform``, UART on a pseudo-terminal).
- ``ulx3s``: the ULX3S (ECP5-85F) target and its open-flow bitstream build.
- ``board_files``: the firmware's board files generated from LiteX's csr.json, and the
  drift check against the committed copies.
"""

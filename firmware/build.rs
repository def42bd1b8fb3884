//! Tells the library whether it is compiled for a RISC-V core without floating-point unit
//! (`cfg(soft_float)`): there every f32 comparison and operation is a library call, and some
//! numeric kernels pick integer formulations of the same results. The target's ISA string
//! names its extensions (`riscv32imac`: none of F, D, G; `riscv32imafc`: F); rustc does not
//! expose F as a `target_feature` on these targets.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(soft_float)");
    println!("cargo::rerun-if-env-changed=TARGET");
    let target = std::env::var("TARGET").unwrap_or_default();
    let isa = target.strip_prefix("riscv32").or_else(|| target.strip_prefix("riscv64"));
    if let Some(isa) = isa {
        let extensions = isa.split('-').next().unwrap_or("");
        if !extensions.contains(['f', 'd', 'g']) {
            println!("cargo::rustc-cfg=soft_float");
        }
    }
}

//! `gridrt completions SHELL`: the shell completion script on stdout.

/// Print a completion script for SHELL on stdout.
///
///   gridrt completions bash > ~/.local/share/bash-completion/completions/gridrt
///   gridrt completions zsh > ~/.zfunc/_gridrt
///   gridrt completions fish > ~/.config/fish/completions/gridrt.fish
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    /// The shell.
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

impl Cmd {
    /// Writes the script for `cli` (the whole command line of `gridrt`).
    pub fn run(self, cli: &mut clap::Command) -> anyhow::Result<()> {
        clap_complete::generate(self.shell, cli, "gridrt", &mut std::io::stdout());
        Ok(())
    }
}

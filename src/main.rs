use clap::Parser;

fn main() {
    // Behave like other Unix tools when piped into `head`: exit quietly on SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = laydown::cli::Cli::parse();
    std::process::exit(laydown::cli::main_with(cli));
}

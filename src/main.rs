use clap::Parser;

fn main() {
    let cli = laydown::cli::Cli::parse();
    std::process::exit(laydown::cli::main_with(cli));
}

fn main() {
    spheremap_cli::progress::install_ctrlc();
    std::process::exit(spheremap_cli::main_with_args(std::env::args_os()));
}

fn main() {
    std::process::exit(spheremap_cli::main_with_args(std::env::args_os()));
}

fn main() {
    detnoise::cli::main();
}

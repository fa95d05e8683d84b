fn main() {
    println!("suslov {}", env!("CARGO_PKG_VERSION"));
}

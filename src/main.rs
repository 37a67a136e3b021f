//! The `advise` command line: a thin layer over the library.

fn main() {
    println!("advise: skeleton; the operator checker lands with the language issue");
}

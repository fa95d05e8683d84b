use suslov::config;
const BASE: &str = include_str!("../examples/paper_eta1.toml");
#[test]
fn print() {
    let long = "x".repeat(900_000);
    let cases = vec![
        BASE.replace("inertia = [1.0, 2.0, 3.0]", "inertia = [1, 2, 3, 4]"),
        BASE.replace("omega_b = \"desired_end\"", "omega_b = [1, 2]"),
        BASE.replace("inertia = [1.0, 2.0, 3.0]", "inertia = 5"),
        BASE.replace("beta = 0.1", &format!("beta = \"{long}\"")),
        BASE.replace("name = \"paper_eta1\"", "name = \"a\\nb\""),
        BASE.replace("name = \"paper_eta1\"", &format!("name = \"{long}\"")),
        BASE.replace("[cost]", &format!("[cost]\n{long} = 1")),
        BASE.replace("beta = 0.1", "beta = 0.1\nbeta = 0.2"),
        BASE.replace(
            "kind = \"paper-spiral\"",
            "kind = \"samples\"\nfile = \"/dev/zero\"",
        )
        .replace("c = 10.0\n", "")
        .replace("width = 0.01\n", "")
        .replace("b_d = 10.0\n", ""),
    ];
    for c in cases {
        match config::from_toml_str(&c) {
            Ok(_) => eprintln!("OK"),
            Err(e) => eprintln!(
                "[{:?}] {}\n",
                e.field().map(|f| f.chars().take(50).collect::<String>()),
                e
            ),
        }
    }
}

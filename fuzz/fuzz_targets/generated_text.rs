//! Any text, escaped for the place where it lands, leaves generated source with the same items
//! and the text as the value of its literals (`hamel_codegen::escape`).
//!
//!     cargo +nightly fuzz run generated_text -- -max_total_time=60
#![no_main]

use hamel_codegen::escape::{doc_comment, package_name, rust_str, toml_str};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let source = format!(
        "{}{}pub const X: &str = {};\n{}fn f() {{}}\n",
        doc_comment("//!", text),
        doc_comment("//", text),
        rust_str(text),
        doc_comment("///", text),
    );
    let file = syn::parse_file(&source).expect("escaped text parses");
    assert_eq!(file.items.len(), 2, "{source}");
    match &file.items[0] {
        syn::Item::Const(c) => match &*c.expr {
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            }) => assert_eq!(s.value(), text),
            other => panic!("not a string literal: {other:?}"),
        },
        other => panic!("not the constant: {other:?}"),
    }
    assert!(matches!(&file.items[1], syn::Item::Fn(f) if f.sig.ident == "f"));
    let toml: toml::Table = format!("v = {}\nw = 1\n", toml_str(text))
        .parse()
        .expect("escaped TOML parses");
    assert_eq!(toml["v"].as_str(), Some(text));
    assert_eq!(toml.len(), 2);
    let name = package_name(&["hamel", text]);
    assert!(name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-'));
});

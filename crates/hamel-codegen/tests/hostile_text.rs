//! Hostile text in every free-text slot of generated code changes no item of it.
//!
//! A crate is generated twice from the same derivation: once with plain text, once with text
//! built to break out of where it lands (newlines, `*/`, quotes, raw-string delimiters,
//! bidirectional overrides, a path that was not UTF-8, very long text) as the command line,
//! the model's and choice's names, the title and the printed quasi-velocities. Every Rust
//! source of both is parsed with `syn`; with doc attributes removed and string literals
//! blanked, the two token streams must be identical, and so must the manifests' structure.
//! The CAS runs in-process, on its one worker thread.

use std::path::Path;

use hamel_codegen::{Generated, generate, with_simulator};
use proc_macro2::{TokenStream, TokenTree};
use quote::ToTokens;

/// Text that would end a line comment, a block comment, a string or a raw string, inject an
/// item, reorder the source's display, and overflow a line.
fn hostile() -> String {
    let not_utf8 = String::from_utf8_lossy(b"models/\xff\xfe/x.toml").into_owned();
    format!(
        "b\nfn injected_by_filename() {{}}\nx.toml\r\n//! injected\r#[doc = \"x\"] */ /* \"; fn s() {{}} r#\"raw\"# r##\"\"## ' \\ \\\" \u{202e}fn evil() {{}}\u{2066} \u{2028}mod m {{}}\u{0} {not_utf8} {}",
        "long ".repeat(20_000)
    )
}

fn knife() -> hamel_derive::Derivation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/knife.toml");
    let model = hamel_model::Model::load(&path).unwrap();
    hamel_derive::derive_for_code(&model, Some("paper")).unwrap()
}

fn crate_of(d: &hamel_derive::Derivation, command: &str) -> Generated {
    with_simulator(generate(d, &[], command).unwrap()).unwrap()
}

/// The tokens of a Rust file with doc attributes removed and string literals blanked.
fn normalised(tokens: TokenStream) -> String {
    let trees: Vec<TokenTree> = tokens.into_iter().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < trees.len() {
        if let Some(skip) = doc_attribute(&trees[i..]) {
            i += skip;
            continue;
        }
        out.push(match &trees[i] {
            TokenTree::Group(g) => format!("{:?}{{{}}}", g.delimiter(), normalised(g.stream())),
            TokenTree::Literal(l) if l.to_string().starts_with('"') => "\"\"".into(),
            t => t.to_string(),
        });
        i += 1;
    }
    out.join(" ")
}

/// The length of a `#[doc …]` or `#![doc …]` attribute at the start of `t`.
fn doc_attribute(t: &[TokenTree]) -> Option<usize> {
    let TokenTree::Punct(p) = t.first()? else {
        return None;
    };
    if p.as_char() != '#' {
        return None;
    }
    let bang = matches!(t.get(1), Some(TokenTree::Punct(p)) if p.as_char() == '!');
    let TokenTree::Group(g) = t.get(1 + usize::from(bang))? else {
        return None;
    };
    let first = g.stream().into_iter().next()?;
    (first.to_string() == "doc").then_some(2 + usize::from(bang))
}

/// Names of the top-level items of a parsed file.
fn item_names(file: &syn::File) -> Vec<String> {
    file.items
        .iter()
        .map(|item| match item {
            syn::Item::Fn(f) => format!("fn {}", f.sig.ident),
            syn::Item::Const(c) => format!("const {}", c.ident),
            syn::Item::Struct(s) => format!("struct {}", s.ident),
            syn::Item::Mod(m) => format!("mod {}", m.ident),
            syn::Item::Impl(_) => "impl".into(),
            syn::Item::Use(_) => "use".into(),
            other => format!("{:?}", std::mem::discriminant(other)),
        })
        .collect()
}

/// The key paths of a TOML document, with the package name's value left out.
fn toml_shape(text: &str) -> Vec<String> {
    fn walk(prefix: &str, v: &toml::Value, out: &mut Vec<String>) {
        match v {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    walk(&format!("{prefix}.{k}"), v, out);
                }
            }
            toml::Value::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    walk(&format!("{prefix}[{i}]"), v, out);
                }
            }
            _ if prefix == ".package.name" => out.push(prefix.into()),
            v => out.push(format!("{prefix} = {v}")),
        }
    }
    let mut out = Vec::new();
    let table: toml::Table = text.parse().unwrap();
    walk("", &toml::Value::Table(table), &mut out);
    out
}

#[test]
fn hostile_text_in_every_slot_changes_no_item() {
    let plain_d = knife();
    let plain = crate_of(
        &plain_d,
        "hamel codegen models/knife.toml --eta paper --out DIR",
    );
    let mut d = plain_d.clone();
    d.model = hostile();
    d.eta_name = hostile();
    d.title = hostile();
    for e in d.eta.iter_mut() {
        e.push_str(&hostile());
    }
    let bad = crate_of(&d, &format!("hamel codegen {} --out DIR", hostile()));
    let paths = |g: &Generated| g.files.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
    assert_eq!(paths(&plain), paths(&bad));
    let mut rust_files = 0;
    for ((path, a), (_, b)) in plain.files.iter().zip(&bad.files) {
        if path.ends_with(".rs") {
            let fa = syn::parse_file(a).unwrap_or_else(|e| panic!("{path} (plain): {e}"));
            let fb = syn::parse_file(b).unwrap_or_else(|e| panic!("{path} (hostile): {e}"));
            assert_eq!(item_names(&fa), item_names(&fb), "{path}");
            assert_eq!(
                normalised(fa.to_token_stream()),
                normalised(fb.to_token_stream()),
                "{path}"
            );
            assert!(!b.contains("\nfn injected_by_filename"), "{path}");
            assert!(!b.contains('\u{202e}') && !b.contains('\u{2028}'), "{path}");
            rust_files += 1;
        } else if path.ends_with("Cargo.toml") {
            assert_eq!(toml_shape(a), toml_shape(b), "{path}");
        }
    }
    assert!(rust_files >= 10, "{rust_files} Rust files");
    // The names still reach the text, escaped: a string literal holds the name exactly.
    let model_rs = &bad.files.iter().find(|f| f.0 == "src/model.rs").unwrap().1;
    let file = syn::parse_file(model_rs).unwrap();
    let model_const = file.items.iter().find_map(|item| match item {
        syn::Item::Const(c) if c.ident == "MODEL" => Some(c.expr.clone()),
        _ => None,
    });
    match model_const.as_deref() {
        Some(syn::Expr::Lit(syn::ExprLit {
            lit: syn::Lit::Str(s),
            ..
        })) => assert_eq!(s.value(), hostile()),
        other => panic!("MODEL is not a string literal: {other:?}"),
    }
}

#[test]
fn names_that_become_code_must_be_identifiers() {
    let mut d = knife();
    let (name, value) = d.parameters.shift_remove_index(0).unwrap();
    d.parameters
        .insert(format!("{name}: f64, pub injected"), value);
    let e = generate(&d, &[], "x").unwrap_err();
    assert!(
        matches!(&e, hamel_codegen::CodegenError::NotAnIdentifier(n) if n.ends_with("pub injected")),
        "{e}"
    );
    assert!(e.to_string().contains("is not an identifier"), "{e}");
    let mut d = knife();
    d.coordinates[0] = "x\n".into();
    assert!(matches!(
        generate(&d, &[], "x"),
        Err(hamel_codegen::CodegenError::NotAnIdentifier(_))
    ));
}

#[test]
fn the_python_export_keeps_hostile_text_in_comments() {
    let x = hamel_expr::parse("sin(a) * b + 2").unwrap().expr;
    let tape = hamel_expr::Tape::compile(&[&x], &["a".into(), "b".into()]).unwrap();
    use hamel_codegen::python::{Input, rhs_function};
    let inputs = [Input::State(0), Input::Number(f64::INFINITY)];
    let plain = rhs_function(&tape, &inputs, "plain");
    let bad = rhs_function(&tape, &inputs, &hostile());
    // Comment lines only, then the same function.
    let code = |s: &str| {
        s.lines()
            .filter(|l| !l.starts_with('#'))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(code(&plain), code(&bad));
    assert!(bad.lines().take_while(|l| l.starts_with('#')).count() >= 3);
    // And Python reads the same program, when it is installed.
    let ast = |src: &str| -> Option<String> {
        let out = std::process::Command::new("python3")
            .args([
                "-c",
                "import ast, sys; print(ast.dump(ast.parse(sys.stdin.read())))",
            ])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .ok()
            .and_then(|mut child| {
                use std::io::Write;
                child.stdin.take()?.write_all(src.as_bytes()).ok()?;
                child.wait_with_output().ok()
            })?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
    };
    match ast(&plain) {
        Some(a) => assert_eq!(Some(a), ast(&bad), "{bad}"),
        None => eprintln!("python3 not found: the Python AST comparison is skipped"),
    }
}

/// Both Python forms (`rhs` returning a list, `rhs_into` writing `dy`), run by python3, give
/// what the tape gives in Rust. Skipped, with a message, where python3 is missing.
#[test]
fn both_python_forms_compute_what_the_tape_computes() {
    use hamel_codegen::python::{Input, rhs_function, rhs_into_function};
    let exprs: Vec<_> = [
        "sin(a) * b + 2",
        "a^3 / (1 + b^2)",
        "sqrt(1 + a^2) - cos(b)*a",
    ]
    .iter()
    .map(|s| hamel_expr::parse(s).unwrap().expr)
    .collect();
    let refs: Vec<_> = exprs.iter().collect();
    let tape = hamel_expr::Tape::compile(&refs, &["a".into(), "b".into()]).unwrap();
    let inputs = [Input::State(1), Input::Number(0.75)];
    let expected = tape.eval::<f64>(&[0.3, 0.75]).unwrap();
    let program = format!(
        "from math import *\n{}{}y = [0.0, 0.3]\ndy = [0.0] * 3\nrhs_into(0.0, y, dy)\nprint(repr(rhs(0.0, y)))\nprint(repr(dy))\n",
        rhs_function(&tape, &inputs, "list"),
        rhs_into_function(&tape, &inputs, "into")
    );
    let Ok(out) = std::process::Command::new("python3")
        .args(["-c", &program])
        .output()
    else {
        eprintln!("python3 not found: skipped");
        return;
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{text}");
    for line in lines {
        let got: Vec<f64> = serde_json::from_str(line).unwrap();
        assert_eq!(got.len(), 3);
        for (g, e) in got.iter().zip(&expected) {
            assert!((g - e).abs() <= 1e-15 * e.abs().max(1.0), "{g} ≠ {e}");
        }
    }
}

//! `#[derive(ConfigDocs)]`: implements `tether_core::config_docs::ConfigDocs` for a
//! configuration struct or enum, listing each named field (an enum's: each variant's
//! named fields, and the enum's own doc as the field `<enum>`) with the last path
//! segment of its type (`Option<f64>` -> `Option`, `tether_core::LaserModel` ->
//! `LaserModel`; a `Vec`'s element type: `Vec<ExtraLaser>` -> `ExtraLaser`) and the first sentence of its doc comment: the lines up to the first
//! that ends with a full stop (design 13, `tether config defaults`).
//!
//! The compiler hands the doc comment over as `#[doc = "..."]` attributes, one a line,
//! so the sentence is taken from what rustdoc reads, not from the files.
//!
//! A number's admissible values are said beside it, `#[config(range = "> 0, <= 1")]`:
//! conditions joined by commas, each `>`, `>=`, `<` or `<=` and a number (or `pi`,
//! `2pi`). The derive
//! checks the text and hands the bounds over parsed (`ValueRange`), so a range that does
//! not parse is a compile error, not a surprise at run time.

use proc_macro::TokenStream;
use quote::quote;
use syn::{Attribute, Data, DeriveInput, Expr, Fields, Lit, Meta, parse_macro_input};

/// See the crate's documentation.
#[proc_macro_derive(ConfigDocs, attributes(config))]
pub fn derive_config_docs(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    let name = &input.ident;
    let strukt = name.to_string();
    let mut entries: Vec<Entry> = Vec::new();
    let listed = match &input.data {
        Data::Struct(s) => named_fields(&s.fields, &mut entries),
        Data::Enum(e) => {
            entries.push(Entry {
                field: "<enum>".into(),
                ty: String::new(),
                doc: first_sentence(&input.attrs),
                range: quote!(None),
            });
            e.variants
                .iter()
                .try_for_each(|variant| named_fields(&variant.fields, &mut entries))
        }
        Data::Union(u) => {
            return syn::Error::new(u.union_token.span, "ConfigDocs is for structs and enums")
                .to_compile_error()
                .into();
        }
    };
    if let Err(e) = listed {
        return e.to_compile_error().into();
    }
    let fields = entries.iter().map(
        |Entry {
             field,
             ty,
             doc,
             range,
         }| {
            quote! {
                ::tether_core::config_docs::FieldDoc {
                    strukt: #strukt,
                    field: #field,
                    ty: #ty,
                    doc: #doc,
                    range: #range,
                }
            }
        },
    );
    let (impl_generics, ty_generics, where_clause) = input.generics.split_for_impl();
    quote! {
        impl #impl_generics ::tether_core::config_docs::ConfigDocs for #name #ty_generics
            #where_clause
        {
            const FIELDS: &'static [::tether_core::config_docs::FieldDoc] = &[#(#fields),*];
        }
    }
    .into()
}

/// What the derive lists of one field.
struct Entry {
    field: String,
    ty: String,
    doc: String,
    /// The `Option<ValueRange>` expression.
    range: proc_macro2::TokenStream,
}

/// The entry of each named field; an error for a range that does not parse.
fn named_fields(fields: &Fields, out: &mut Vec<Entry>) -> syn::Result<()> {
    if let Fields::Named(named) = fields {
        for f in &named.named {
            let Some(ident) = &f.ident else { continue };
            let ty = &f.ty;
            let text = quote!(#ty).to_string();
            let mut base = last_segment(&text);
            // A list's elements are what its tables are (`[[extra_lasers]]`).
            if base == "Vec"
                && let Some((_, inner)) = text.split_once('<')
            {
                base = last_segment(inner.rsplit_once('>').map_or(inner, |(i, _)| i));
            }
            out.push(Entry {
                field: ident.to_string(),
                ty: base,
                doc: first_sentence(&f.attrs),
                range: range(&f.attrs)?,
            });
        }
    }
    Ok(())
}

/// The `#[config(range = "...")]` of a field as an `Option<ValueRange>` expression.
fn range(attrs: &[Attribute]) -> syn::Result<proc_macro2::TokenStream> {
    let mut found = None;
    for attr in attrs.iter().filter(|a| a.path().is_ident("config")) {
        attr.parse_nested_meta(|meta| {
            if !meta.path.is_ident("range") {
                return Err(meta.error("the one setting of #[config] is `range = \"...\"`"));
            }
            let text: syn::LitStr = meta.value()?.parse()?;
            let (min, max) =
                bounds(&text.value()).map_err(|why| syn::Error::new(text.span(), why))?;
            // The bits, not a literal: clippy would take 6.283185307179586 for a
            // mistyped TAU.
            let bound = |b: Option<(f64, bool)>| match b {
                Some((x, inclusive)) => {
                    let bits = x.to_bits();
                    quote!(Some((f64::from_bits(#bits), #inclusive)))
                }
                None => quote!(None),
            };
            let (min, max) = (bound(min), bound(max));
            let text = text.value();
            found = Some(quote! {
                Some(::tether_core::config_docs::ValueRange { text: #text, min: #min, max: #max })
            });
            Ok(())
        })?;
    }
    Ok(found.unwrap_or_else(|| quote!(None)))
}

/// A bound: its value and whether it is admitted.
type Bound = Option<(f64, bool)>;

/// The lower and upper bounds of a range's text, `"> 0, <= 1"`.
fn bounds(text: &str) -> Result<(Bound, Bound), String> {
    let (mut min, mut max) = (None, None);
    for condition in text.split(',') {
        let condition = condition.trim();
        let (op, number) = ["<=", ">=", "<", ">"]
            .iter()
            .find_map(|op| Some((*op, condition.strip_prefix(op)?)))
            .ok_or_else(|| format!("`{condition}`: a condition is <, <=, > or >= and a number"))?;
        let x: f64 = match number.trim() {
            "pi" => std::f64::consts::PI,
            "2pi" => std::f64::consts::TAU,
            n => n
                .parse()
                .map_err(|_| format!("`{condition}`: `{n}` is not a number (or pi, 2pi)"))?,
        };
        let slot = if op.starts_with('>') {
            &mut min
        } else {
            &mut max
        };
        if slot.replace((x, op.ends_with('='))).is_some() {
            return Err(format!(
                "`{text}`: two {} bounds",
                if op.starts_with('>') {
                    "lower"
                } else {
                    "upper"
                }
            ));
        }
    }
    if let (Some((lo, _)), Some((hi, _))) = (min, max)
        && lo > hi
    {
        return Err(format!("`{text}`: no number is in it"));
    }
    Ok((min, max))
}

/// The last path segment of a type's text without its generics: `Option < f64 >` ->
/// `Option`, `tether_core :: LaserModel` -> `LaserModel`.
fn last_segment(text: &str) -> String {
    let base = text.split('<').next().unwrap_or(text);
    base.rsplit("::").next().unwrap_or(base).trim().to_string()
}

/// The doc comment's lines up to the first that ends with a full stop, joined by
/// spaces (empty lines skipped).
fn first_sentence(attrs: &[Attribute]) -> String {
    let mut doc: Option<String> = None;
    for attr in attrs {
        let Meta::NameValue(nv) = &attr.meta else {
            continue;
        };
        if !nv.path.is_ident("doc") {
            continue;
        }
        let Expr::Lit(lit) = &nv.value else { continue };
        let Lit::Str(s) = &lit.lit else { continue };
        let line = s.value();
        let line = line.trim();
        match &mut doc {
            None => doc = Some(line.to_owned()),
            Some(so_far) if !so_far.ends_with('.') && !line.is_empty() => {
                so_far.push(' ');
                so_far.push_str(line);
            }
            Some(_) => {}
        }
    }
    doc.unwrap_or_default()
}

//! `#[derive(ConfigDocs)]`: implements `tether_core::config_docs::ConfigDocs` for a
//! configuration struct or enum, listing each named field (an enum's: each variant's
//! named fields, and the enum's own doc as the field `<enum>`) with the last path
//! segment of its type (`Option<f64>` -> `Option`, `tether_core::LaserModel` ->
//! `LaserModel`; a `Vec`'s element type: `Vec<ExtraLaser>` -> `ExtraLaser`) and the first sentence of its doc comment: the lines up to the first
//! that ends with a full stop (design 13, `tether config defaults`).
//!
//! The compiler hands the doc comment over as `#[doc = "..."]` attributes, one a line,
//! so the sentence is taken from what rustdoc reads, not from the files.

use proc_macro::TokenStream;
use quote::quote;
use syn::{Attribute, Data, DeriveInput, Expr, Fields, Lit, Meta, parse_macro_input};

/// See the crate's documentation.
#[proc_macro_derive(ConfigDocs)]
pub fn derive_config_docs(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    let name = &input.ident;
    let strukt = name.to_string();
    let mut entries: Vec<(String, String, String)> = Vec::new();
    match &input.data {
        Data::Struct(s) => named_fields(&s.fields, &mut entries),
        Data::Enum(e) => {
            entries.push(("<enum>".into(), String::new(), first_sentence(&input.attrs)));
            for variant in &e.variants {
                named_fields(&variant.fields, &mut entries);
            }
        }
        Data::Union(u) => {
            return syn::Error::new(u.union_token.span, "ConfigDocs is for structs and enums")
                .to_compile_error()
                .into();
        }
    }
    let fields = entries.iter().map(|(field, ty, doc)| {
        quote! {
            ::tether_core::config_docs::FieldDoc {
                strukt: #strukt,
                field: #field,
                ty: #ty,
                doc: #doc,
            }
        }
    });
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

/// `(field, type, doc)` of each named field.
fn named_fields(fields: &Fields, out: &mut Vec<(String, String, String)>) {
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
            out.push((ident.to_string(), base, first_sentence(&f.attrs)));
        }
    }
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

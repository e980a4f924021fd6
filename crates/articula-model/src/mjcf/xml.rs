//! The MJCF document as one element tree: files read with their `<include>`s spliced in,
//! `<default>` classes resolved, `<compiler>` settings, and typed attribute access whose errors
//! name the file, element and attribute.

use crate::urdf::{check_markup, read_model_bytes, MAX_XML_ATTRIBUTES, MAX_XML_DEPTH};
use crate::ModelError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// At most this many `<include>`d files (and this deep), so a file including itself stops.
const MAX_INCLUDES: usize = 256;

/// An element with its attributes and children, and where it was read.
#[derive(Clone, Debug)]
pub(crate) struct El {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<El>,
    /// Index into [`Doc::files`].
    pub file: usize,
    /// 1-based line.
    pub line: u32,
}

impl El {
    /// The attribute as written on the element.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The child elements with this tag.
    pub fn each<'a>(&'a self, tag: &'a str) -> impl Iterator<Item = &'a El> + 'a {
        self.children.iter().filter(move |c| c.tag == tag)
    }

    /// `<tag name="...">` (line n), for messages.
    pub fn describe(&self) -> String {
        match self.attr("name") {
            Some(n) => format!("<{} name=\"{n}\"> (line {})", self.tag, self.line),
            None => format!("<{}> (line {})", self.tag, self.line),
        }
    }
}

/// The files of one model and its root `<mujoco>` element, includes spliced in.
pub(crate) struct Doc {
    pub files: Vec<String>,
    pub root: El,
    /// The main file's directory (asset files are resolved against it), `None` for text.
    pub dir: Option<PathBuf>,
}

impl Doc {
    /// An error about `el` (and `attribute`).
    pub fn err(&self, el: &El, attribute: Option<&str>, message: impl Into<String>) -> ModelError {
        ModelError::Mjcf {
            file: self.files[el.file].clone(),
            element: el.describe(),
            attribute: attribute.map(str::to_string),
            message: message.into(),
        }
    }

    /// Reads a file and its includes (resolved against the main file's directory, as MuJoCo
    /// does).
    pub fn read_file(path: &Path) -> Result<Doc, ModelError> {
        let mut files = Vec::new();
        let dir = path.parent().map(Path::to_path_buf);
        let text = read_text(path)?;
        let root = parse(
            &text,
            path.display().to_string(),
            dir.as_deref(),
            &mut files,
        )?;
        Ok(Doc { files, root, dir })
    }

    /// Reads a model from text; an `<include>` is then an error (it has no directory).
    pub fn read_str(text: &str) -> Result<Doc, ModelError> {
        let mut files = Vec::new();
        let root = parse(text, "<string>".into(), None, &mut files)?;
        Ok(Doc {
            files,
            root,
            dir: None,
        })
    }
}

fn read_text(path: &Path) -> Result<String, ModelError> {
    let bytes = read_model_bytes(path, "MJCF")?;
    String::from_utf8(bytes).map_err(|e| ModelError::NotText {
        reason: format!("invalid UTF-8 in {}", path.display()),
        offset: e.utf8_error().valid_up_to(),
    })
}

/// Parses one file's text into its root element (`<mujoco>`), includes spliced in.
fn parse(
    text: &str,
    label: String,
    dir: Option<&Path>,
    files: &mut Vec<String>,
) -> Result<El, ModelError> {
    if text.trim().is_empty() {
        return Err(ModelError::Empty);
    }
    if let Some(offset) = text.bytes().position(|b| b == 0) {
        return Err(ModelError::NotText {
            reason: "NUL byte".into(),
            offset,
        });
    }
    check_markup(text, MAX_XML_DEPTH, MAX_XML_ATTRIBUTES)?;
    let doc = roxmltree::Document::parse(text).map_err(|e| ModelError::Mjcf {
        file: label.clone(),
        element: "the document".into(),
        attribute: None,
        message: format!("malformed XML: {e}"),
    })?;
    let file = files.len();
    files.push(label);
    let root = doc.root_element();
    if root.tag_name().name() != "mujoco" {
        return Err(ModelError::Mjcf {
            file: files[file].clone(),
            element: format!("<{}>", root.tag_name().name()),
            attribute: None,
            message: "the root element of an MJCF file must be <mujoco>".into(),
        });
    }
    convert(&doc, root, file, dir, files)
}

fn convert(
    doc: &roxmltree::Document,
    node: roxmltree::Node,
    file: usize,
    dir: Option<&Path>,
    files: &mut Vec<String>,
) -> Result<El, ModelError> {
    let mut el = El {
        tag: node.tag_name().name().to_string(),
        attrs: node
            .attributes()
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect(),
        children: Vec::new(),
        file,
        line: doc.text_pos_at(node.range().start).row,
    };
    for c in node.children().filter(|n| n.is_element()) {
        if c.tag_name().name() != "include" {
            el.children.push(convert(doc, c, file, dir, files)?);
            continue;
        }
        let inc = convert(doc, c, file, dir, files)?;
        let err = |message: String| ModelError::Mjcf {
            file: files[file].clone(),
            element: inc.describe(),
            attribute: Some("file".into()),
            message,
        };
        let Some(name) = inc.attr("file") else {
            return Err(err("an <include> needs a 'file'".into()));
        };
        let Some(dir) = dir else {
            return Err(err(
                "an <include> needs the model's directory: load the model from its file".into(),
            ));
        };
        if files.len() >= MAX_INCLUDES {
            return Err(err(format!(
                "more than {MAX_INCLUDES} included files (does a file include itself?)"
            )));
        }
        let path: PathBuf = dir.join(name);
        let text = read_text(&path)?;
        let sub = parse(&text, path.display().to_string(), Some(dir), files)?;
        el.children.extend(sub.children);
    }
    Ok(el)
}

/// Attribute values of the `<default>` classes: class → element tag → attributes, each class
/// holding its parents' values overridden by its own.
#[derive(Default)]
pub(crate) struct Defaults {
    classes: HashMap<String, HashMap<String, Vec<(String, String)>>>,
}

/// The class of every element without `class` or inherited `childclass`.
pub(crate) const MAIN: &str = "main";

impl Defaults {
    /// Reads every top-level `<default>` (and the classes nested in it).
    pub fn read(doc: &Doc) -> Result<Defaults, ModelError> {
        let mut out = Defaults::default();
        for d in doc.root.each("default") {
            let name = d.attr("class").unwrap_or(MAIN);
            out.walk(doc, d, name, HashMap::new())?;
        }
        out.classes.entry(MAIN.into()).or_default();
        Ok(out)
    }

    fn walk(
        &mut self,
        doc: &Doc,
        el: &El,
        name: &str,
        mut values: HashMap<String, Vec<(String, String)>>,
    ) -> Result<(), ModelError> {
        if self.classes.contains_key(name) && name != MAIN {
            return Err(doc.err(
                el,
                Some("class"),
                format!("repeated default class '{name}'"),
            ));
        }
        for c in el.children.iter().filter(|c| c.tag != "default") {
            let slot = values.entry(c.tag.clone()).or_default();
            for (k, v) in &c.attrs {
                match slot.iter_mut().find(|(x, _)| x == k) {
                    Some(s) => s.1 = v.clone(),
                    None => slot.push((k.clone(), v.clone())),
                }
            }
        }
        self.classes.insert(name.to_string(), values.clone());
        for c in el.each("default") {
            let Some(child) = c.attr("class") else {
                return Err(doc.err(c, Some("class"), "a nested <default> needs a class"));
            };
            self.walk(doc, c, child, values.clone())?;
        }
        Ok(())
    }

    /// The defaults of `tag` in `class`, or an error naming `el` for an unknown class.
    pub fn of<'a>(
        &'a self,
        doc: &Doc,
        el: &El,
        class: &str,
    ) -> Result<Option<&'a Vec<(String, String)>>, ModelError> {
        let Some(c) = self.classes.get(class) else {
            return Err(doc.err(
                el,
                Some("class"),
                format!("unknown default class '{class}'"),
            ));
        };
        Ok(c.get(&el.tag))
    }
}

/// An element with its class defaults: attributes are the element's own, else its class's.
pub(crate) struct Attrs<'a> {
    pub doc: &'a Doc,
    pub el: &'a El,
    pub defaults: Option<&'a Vec<(String, String)>>,
}

impl<'a> Attrs<'a> {
    /// `el` with the defaults of its class (its `class`, else `childclass`).
    pub fn new(
        doc: &'a Doc,
        defaults: &'a Defaults,
        el: &'a El,
        childclass: &str,
    ) -> Result<Attrs<'a>, ModelError> {
        let class = el.attr("class").unwrap_or(childclass);
        Ok(Attrs {
            doc,
            el,
            defaults: defaults.of(doc, el, class)?,
        })
    }

    /// `el` alone (bodies, inertials and frames take no defaults).
    pub fn plain(doc: &'a Doc, el: &'a El) -> Attrs<'a> {
        Attrs {
            doc,
            el,
            defaults: None,
        }
    }

    /// The attribute's text.
    pub fn get(&self, name: &str) -> Option<&'a str> {
        self.el.attr(name).or_else(|| {
            self.defaults?
                .iter()
                .find(|(k, _)| k == name)
                .map(|(_, v)| v.as_str())
        })
    }

    /// An error about this element and `attribute`.
    pub fn err(&self, attribute: &str, message: impl Into<String>) -> ModelError {
        self.doc.err(self.el, Some(attribute), message)
    }

    /// Between `min` and `max` finite numbers, or `None` when absent.
    pub fn numbers(
        &self,
        name: &str,
        min: usize,
        max: usize,
    ) -> Result<Option<Vec<f64>>, ModelError> {
        let Some(text) = self.get(name) else {
            return Ok(None);
        };
        let mut out = Vec::new();
        for word in text.split_ascii_whitespace() {
            match word.parse::<f64>() {
                Ok(x) if x.is_finite() => out.push(x),
                _ => return Err(self.err(name, format!("'{word}' is not a finite number"))),
            }
        }
        if out.len() < min || out.len() > max {
            let want = if min == max {
                format!("{min}")
            } else {
                format!("{min} to {max}")
            };
            return Err(self.err(
                name,
                format!("expected {want} numbers, found {}", out.len()),
            ));
        }
        Ok(Some(out))
    }

    /// Exactly `N` numbers, or `None` when absent.
    pub fn array<const N: usize>(&self, name: &str) -> Result<Option<[f64; N]>, ModelError> {
        Ok(self
            .numbers(name, N, N)?
            .map(|v| std::array::from_fn(|i| v[i])))
    }

    /// One number, or `default`.
    pub fn number(&self, name: &str, default: f64) -> Result<f64, ModelError> {
        Ok(self.array::<1>(name)?.map_or(default, |[x]| x))
    }

    /// `true`/`false` (or `auto`: `None`); `default` when absent.
    pub fn flag(&self, name: &str, default: Option<bool>) -> Result<Option<bool>, ModelError> {
        match self.get(name) {
            None => Ok(default),
            Some("true") => Ok(Some(true)),
            Some("false") => Ok(Some(false)),
            Some("auto") => Ok(None),
            Some(x) => Err(self.err(name, format!("expected true, false or auto, found '{x}'"))),
        }
    }
}

/// `<compiler>` settings that change what is computed.
#[derive(Clone, Debug)]
pub(crate) struct Compiler {
    /// `angle="degree"` (MuJoCo's default) rather than radian.
    pub degree: bool,
    /// `eulerseq`: three of `xyzXYZ` (lower case: axes that rotate with the frame).
    pub eulerseq: [u8; 3],
    /// `autolimits`: a joint with a `range` is limited unless it says otherwise.
    pub autolimits: bool,
    /// `inertiafromgeom`: `Some(true)` always, `Some(false)` never, `None` (auto) for bodies
    /// without `<inertial>`.
    pub inertia_from_geom: Option<bool>,
    /// `inertiagrouprange`: the geom groups that contribute mass.
    pub inertia_groups: [i64; 2],
    /// `settotalmass`: scale every body's mass and inertia to this total.
    pub total_mass: Option<f64>,
    /// `meshdir` (else `assetdir`): mesh files' directory, relative to the model's.
    pub meshdir: Option<String>,
}

impl Compiler {
    pub fn read(doc: &Doc) -> Result<Compiler, ModelError> {
        let mut c = Compiler {
            degree: true,
            eulerseq: *b"xyz",
            autolimits: true,
            inertia_from_geom: None,
            inertia_groups: [0, 5],
            total_mass: None,
            meshdir: None,
        };
        for el in doc.root.each("compiler") {
            let a = Attrs::plain(doc, el);
            match a.get("angle") {
                None => {}
                Some("degree") => c.degree = true,
                Some("radian") => c.degree = false,
                Some(x) => {
                    return Err(a.err("angle", format!("expected degree or radian, found '{x}'")))
                }
            }
            if let Some(seq) = a.get("eulerseq") {
                let b = seq.as_bytes();
                if b.len() != 3 || !b.iter().all(|x| b"xyzXYZ".contains(x)) {
                    return Err(a.err(
                        "eulerseq",
                        format!("expected three of xyzXYZ, found '{seq}'"),
                    ));
                }
                c.eulerseq = [b[0], b[1], b[2]];
            }
            if let Some(x) = a.flag("autolimits", None)? {
                c.autolimits = x;
            }
            if a.get("inertiafromgeom").is_some() {
                c.inertia_from_geom = a.flag("inertiafromgeom", None)?;
            }
            if let Some([lo, hi]) = a.array::<2>("inertiagrouprange")? {
                c.inertia_groups = [lo as i64, hi as i64];
            }
            if let Some([m]) = a.array::<1>("settotalmass")? {
                c.total_mass = (m > 0.0).then_some(m);
            }
            if let Some(dir) = a.get("meshdir").or_else(|| a.get("assetdir")) {
                c.meshdir = Some(dir.to_string());
            }
            if a.get("coordinate").is_some_and(|x| x != "local") {
                return Err(a.err(
                    "coordinate",
                    "only local coordinates are read (MuJoCo removed 'global')",
                ));
            }
        }
        Ok(c)
    }

    /// An angle attribute in radians.
    pub fn angle(&self, x: f64) -> f64 {
        if self.degree {
            x.to_radians()
        } else {
            x
        }
    }
}

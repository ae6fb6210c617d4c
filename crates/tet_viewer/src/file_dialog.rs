//! An in-window file browser, so the viewer needs no system dialog library
//! (no GTK or portal: the machines it runs on have only the Rust toolchain
//! and an X server).
//!
//! * [`FileDialog`]: the model, without a window — the folder shown, its
//!   [`Entry`]s (folders first, then files with one of the wanted
//!   extensions, each group sorted by name, case-insensitively), navigation
//!   up and into folders, the typed or picked file name, and
//!   [`FileDialog::choose`], which validates the name for the [`Mode`] and
//!   returns the chosen path.
//! * [`show`]: draws a dialog in an egui window and reports [`Outcome`]s.
//!
//! A folder that cannot be listed (missing, not a folder, no permission)
//! never panics: the dialog stays where it was and shows the reason in
//! [`FileDialog::message`].

use eframe::egui;
use std::path::{Path, PathBuf};

/// Whether the dialog picks an existing file or names one to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Open,
    Save,
}

/// One listed folder or file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// The name shown (lossy UTF-8 for names that are not).
    pub name: String,
    pub path: PathBuf,
    pub is_dir: bool,
}

/// The browser's state; see the module documentation.
#[derive(Debug, Clone)]
pub struct FileDialog {
    mode: Mode,
    dir: PathBuf,
    /// Lower-case extensions without the dot; empty lists every file.
    extensions: Vec<String>,
    entries: Vec<Entry>,
    file_name: String,
    show_hidden: bool,
    message: Option<String>,
}

impl FileDialog {
    /// A dialog in `mode` listing `dir` (the current folder when `dir` is
    /// empty or cannot be listed; `message` then says why), showing files
    /// that end in one of `extensions` (`"json"`, `".PNG"`: case and dot
    /// do not matter).
    pub fn new(mode: Mode, dir: &Path, extensions: &[&str]) -> FileDialog {
        let extensions = extensions
            .iter()
            .map(|e| e.trim_start_matches('.').to_ascii_lowercase())
            .filter(|e| !e.is_empty())
            .collect();
        let mut d = FileDialog {
            mode,
            dir: PathBuf::new(),
            extensions,
            entries: Vec::new(),
            file_name: String::new(),
            show_hidden: false,
            message: None,
        };
        let start = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
        if !d.go_to(start) {
            let why = d.message.take();
            if !d.go_to(Path::new(".")) {
                // Not even the current folder lists: keep the path and the reason.
                d.dir = absolute(start);
            }
            d.message = why;
        }
        d
    }

    /// A dialog for a path text field: starts in the folder of `field`
    /// (relative to the current folder) with its file name typed in.
    pub fn for_field(mode: Mode, field: &str, extensions: &[&str]) -> FileDialog {
        let p = Path::new(field.trim());
        let (dir, name) = if p.is_dir() {
            (p.to_path_buf(), String::new())
        } else {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            (p.parent().map(Path::to_path_buf).unwrap_or_default(), name)
        };
        let mut d = FileDialog::new(mode, &dir, extensions);
        d.file_name = name;
        d
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }
    /// The folder listed (absolute).
    pub fn dir(&self) -> &Path {
        &self.dir
    }
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
    pub fn extensions(&self) -> &[String] {
        &self.extensions
    }
    pub fn file_name(&self) -> &str {
        &self.file_name
    }
    pub fn set_file_name(&mut self, name: &str) {
        self.file_name = name.to_string();
    }
    /// Why the last navigation or listing failed, if it did.
    pub fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }
    pub fn show_hidden(&self) -> bool {
        self.show_hidden
    }
    /// Shows or hides names starting with a dot (re-lists).
    pub fn set_show_hidden(&mut self, show: bool) {
        if show != self.show_hidden {
            self.show_hidden = show;
            self.refresh();
        }
    }

    /// Lists `dir` and makes it the current folder; on failure stays where
    /// it was, sets [`message`](Self::message) and returns false.
    pub fn go_to(&mut self, dir: &Path) -> bool {
        let dir = absolute(dir);
        match list(&dir, &self.extensions, self.show_hidden) {
            Ok(entries) => {
                self.dir = dir;
                self.entries = entries;
                self.message = None;
                true
            }
            Err(e) => {
                self.message = Some(format!("cannot list {}: {e}", dir.display()));
                false
            }
        }
    }

    /// Re-lists the current folder (empty, with a message, when it no
    /// longer lists).
    pub fn refresh(&mut self) {
        let dir = self.dir.clone();
        if !self.go_to(&dir) {
            self.entries.clear();
        }
    }

    /// Goes to the parent folder; false at the root or when it does not list.
    pub fn up(&mut self) -> bool {
        match self.dir.parent().map(Path::to_path_buf) {
            Some(p) => self.go_to(&p),
            None => false,
        }
    }

    /// Activates entry `i`: enters a folder, or takes a file's name. Returns
    /// whether the entry was a file (a double click then chooses it).
    pub fn activate(&mut self, i: usize) -> bool {
        let Some(e) = self.entries.get(i).cloned() else { return false };
        if e.is_dir {
            self.go_to(&e.path);
            false
        } else {
            self.file_name = e.name;
            true
        }
    }

    /// The path the typed name stands for, validated for the mode: in
    /// [`Mode::Open`] an existing file; in [`Mode::Save`] a plain file name
    /// (see [`validate_save_name`]; the first extension is appended when
    /// the name has none of them) that is not a folder. The name may also be
    /// an absolute path.
    pub fn choose(&self) -> Result<PathBuf, String> {
        let name = self.file_name.trim();
        if name.is_empty() {
            return Err("type or pick a file name".into());
        }
        match self.mode {
            Mode::Open => {
                let p = self.dir.join(name);
                if p.is_file() {
                    Ok(p)
                } else if p.is_dir() {
                    Err(format!("{} is a folder", p.display()))
                } else {
                    Err(format!("no file {}", p.display()))
                }
            }
            Mode::Save => {
                let (dir, name) = match Path::new(name).is_absolute() {
                    true => {
                        let p = Path::new(name);
                        let file = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                        (p.parent().map(Path::to_path_buf).unwrap_or_default(), file)
                    }
                    false => (self.dir.clone(), name.to_string()),
                };
                let name = validate_save_name(&name, &self.extensions)?;
                if !dir.is_dir() {
                    return Err(format!("no folder {}", dir.display()));
                }
                let p = dir.join(name);
                if p.is_dir() {
                    return Err(format!("{} is a folder", p.display()));
                }
                Ok(p)
            }
        }
    }
}

/// A file name to save under: not empty, not `.` or `..`, without path
/// separators or NUL; the first of `extensions` is appended when it ends
/// in none of them (case-insensitive).
pub fn validate_save_name(name: &str, extensions: &[String]) -> Result<String, String> {
    let name = name.trim();
    if name.is_empty() {
        return Err("the file name is empty".into());
    }
    if name == "." || name == ".." {
        return Err(format!("{name:?} is not a file name"));
    }
    if name.contains(['/', '\\', '\0']) {
        return Err(format!("{name:?}: a file name cannot contain / or \\ (browse to the folder instead)"));
    }
    match extensions.first() {
        Some(first) if !has_extension(Path::new(name), extensions) => Ok(format!("{name}.{first}")),
        _ => Ok(name.to_string()),
    }
}

fn has_extension(p: &Path, extensions: &[String]) -> bool {
    extensions.is_empty()
        || p.extension().is_some_and(|e| extensions.iter().any(|x| e.to_string_lossy().eq_ignore_ascii_case(x)))
}

/// `p` made absolute against the current folder (without resolving links,
/// so ".." goes up the path as shown).
fn absolute(p: &Path) -> PathBuf {
    let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    // Drop "." and fold ".." so the shown path stays short.
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// Folders first, then files with a wanted extension; each sorted by name.
/// Entries whose type cannot be read (a dangling link) are left out.
fn list(dir: &Path, extensions: &[String], show_hidden: bool) -> std::io::Result<Vec<Entry>> {
    let mut out = Vec::new();
    for item in std::fs::read_dir(dir)? {
        let Ok(item) = item else { continue };
        let name = item.file_name().to_string_lossy().into_owned();
        if !show_hidden && name.starts_with('.') {
            continue;
        }
        let path = item.path();
        // Follows links, so a link to a folder is a folder.
        let Ok(meta) = std::fs::metadata(&path) else { continue };
        let is_dir = meta.is_dir();
        if !is_dir && !has_extension(&path, extensions) {
            continue;
        }
        out.push(Entry { name, path, is_dir });
    }
    out.sort_by(|a, b| b.is_dir.cmp(&a.is_dir).then_with(|| a.name.to_lowercase().cmp(&b.name.to_lowercase())));
    Ok(out)
}

/// What the user did in the dialog this frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    Chosen(PathBuf),
    Cancelled,
}

/// Draws `dialog` in a window titled `title`; `Some` once the user chose a
/// path or cancelled (the caller then drops the dialog).
pub fn show(ctx: &egui::Context, title: &str, dialog: &mut FileDialog) -> Option<Outcome> {
    let mut outcome = None;
    let mut open = true;
    egui::Window::new(title)
        .id(egui::Id::unique("tetview-file-dialog"))
        .open(&mut open)
        .collapsible(false)
        .resizable(true)
        .default_size([420.0, 360.0])
        .show(ctx, |ui| {
            ui.horizontal(|ui| {
                if ui.button("⬆ up").clicked() {
                    dialog.up();
                }
                if ui.button("refresh").clicked() {
                    dialog.refresh();
                }
                let mut hidden = dialog.show_hidden();
                if ui.checkbox(&mut hidden, "hidden").changed() {
                    dialog.set_show_hidden(hidden);
                }
            });
            ui.label(dialog.dir().display().to_string());
            if !dialog.extensions().is_empty() {
                let exts: Vec<String> = dialog.extensions().iter().map(|e| format!(".{e}")).collect();
                ui.weak(format!("showing folders and {} files", exts.join(", ")));
            }
            let mut activated = None;
            let mut chosen_now = false;
            egui::ScrollArea::vertical().max_height(220.0).auto_shrink([false, true]).show(ui, |ui| {
                if dialog.entries().is_empty() {
                    ui.weak("(empty)");
                }
                for (i, e) in dialog.entries().iter().enumerate() {
                    let label = if e.is_dir { format!("📁 {}/", e.name) } else { format!("   {}", e.name) };
                    let sel = !e.is_dir && e.name == dialog.file_name();
                    let r = ui.selectable_label(sel, label);
                    if r.double_clicked() {
                        activated = Some(i);
                        chosen_now = !e.is_dir;
                    } else if r.clicked() {
                        activated = Some(i);
                    }
                }
            });
            if let Some(i) = activated {
                let is_file = dialog.activate(i);
                if !(is_file && chosen_now) {
                    chosen_now = false;
                }
            }
            let mut name = dialog.file_name().to_string();
            let enter = ui
                .horizontal(|ui| {
                    ui.label("file name");
                    let r = ui.text_edit_singleline(&mut name);
                    r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter))
                })
                .inner;
            if name != dialog.file_name() {
                dialog.set_file_name(&name);
            }
            let check = dialog.choose();
            if let (Mode::Save, Ok(p)) = (dialog.mode(), &check) {
                if p.exists() {
                    ui.colored_label(
                        egui::Color32::LIGHT_YELLOW,
                        format!("{} exists: saving replaces it", p.display()),
                    );
                }
            }
            if let Some(m) = dialog.message() {
                ui.colored_label(egui::Color32::LIGHT_RED, m);
            }
            ui.horizontal(|ui| {
                let verb = if dialog.mode() == Mode::Open { "open" } else { "choose" };
                let ok = ui.add_enabled(check.is_ok(), egui::Button::new(verb));
                let ok = match &check {
                    Err(e) if !dialog.file_name().trim().is_empty() => ok.on_disabled_hover_text(e.as_str()),
                    _ => ok,
                };
                if ok.clicked() || ((enter || chosen_now) && check.is_ok()) {
                    if let Ok(p) = &check {
                        outcome = Some(Outcome::Chosen(p.clone()));
                    }
                }
                if ui.button("cancel").clicked() {
                    outcome = Some(Outcome::Cancelled);
                }
            });
        });
    if !open && outcome.is_none() {
        outcome = Some(Outcome::Cancelled);
    }
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree() -> tempfile::TempDir {
        let t = tempfile::tempdir().unwrap();
        let r = t.path();
        std::fs::create_dir(r.join("b_dir")).unwrap();
        std::fs::create_dir(r.join("A_dir")).unwrap();
        std::fs::create_dir(r.join(".hidden_dir")).unwrap();
        for f in ["z.json", "a.JSON", "m.png", "notes.txt", ".dot.json", "b_dir/inner.json"] {
            std::fs::write(r.join(f), b"{}").unwrap();
        }
        t
    }

    fn names(d: &FileDialog) -> Vec<&str> {
        d.entries().iter().map(|e| e.name.as_str()).collect()
    }

    #[test]
    fn lists_folders_first_then_matching_files() {
        let t = tree();
        let d = FileDialog::new(Mode::Open, t.path(), &[".json"]);
        assert_eq!(d.message(), None);
        assert_eq!(names(&d), ["A_dir", "b_dir", "a.JSON", "z.json"]);
        assert!(d.entries()[0].is_dir && !d.entries()[2].is_dir);
        let d = FileDialog::new(Mode::Open, t.path(), &["png", "JSON"]);
        assert_eq!(names(&d), ["A_dir", "b_dir", "a.JSON", "m.png", "z.json"]);
        let mut d = FileDialog::new(Mode::Open, t.path(), &[]);
        assert_eq!(names(&d), ["A_dir", "b_dir", "a.JSON", "m.png", "notes.txt", "z.json"]);
        d.set_show_hidden(true);
        assert_eq!(names(&d)[0], ".hidden_dir");
        assert!(names(&d).contains(&".dot.json"));
    }

    #[test]
    fn navigates_into_and_up_and_picks() {
        let t = tree();
        let root = absolute(t.path());
        let mut d = FileDialog::new(Mode::Open, t.path(), &["json"]);
        assert!(!d.activate(1), "b_dir is a folder");
        assert_eq!(d.dir(), root.join("b_dir"));
        assert_eq!(names(&d), ["inner.json"]);
        assert!(d.activate(0));
        assert_eq!(d.file_name(), "inner.json");
        assert_eq!(d.choose().unwrap(), root.join("b_dir/inner.json"));
        assert!(d.up());
        assert_eq!(d.dir(), root);
        // Out-of-range entries do nothing.
        assert!(!d.activate(99));
        assert_eq!(d.dir(), root);
        // Up to the root, then no further.
        while d.up() {}
        assert!(d.dir().parent().is_none());
    }

    #[test]
    fn unlistable_folders_are_a_message_not_a_panic() {
        let t = tree();
        let root = absolute(t.path());
        let mut d = FileDialog::new(Mode::Open, t.path(), &["json"]);
        assert!(!d.go_to(&root.join("missing")));
        assert_eq!(d.dir(), root, "stays where it was");
        assert!(d.message().unwrap().contains("missing"), "{:?}", d.message());
        assert!(!d.go_to(&root.join("z.json")), "a file is not a folder");
        assert!(d.go_to(&root));
        assert_eq!(d.message(), None);
        // The folder vanishing under the dialog: refresh empties it with a message.
        let gone = root.join("A_dir");
        assert!(d.go_to(&gone));
        std::fs::remove_dir(&gone).unwrap();
        d.refresh();
        assert!(d.entries().is_empty() && d.message().is_some());
        // Starting in a missing folder falls back to the current one, with the reason.
        let d = FileDialog::new(Mode::Save, &root.join("nope/deeper"), &["json"]);
        assert!(d.message().unwrap().contains("nope"));
        assert_eq!(d.dir(), absolute(Path::new(".")));
    }

    #[test]
    fn open_needs_an_existing_file() {
        let t = tree();
        let mut d = FileDialog::new(Mode::Open, t.path(), &["json"]);
        assert!(d.choose().is_err(), "no name yet");
        d.set_file_name("absent.json");
        assert!(d.choose().unwrap_err().contains("no file"));
        d.set_file_name("b_dir");
        assert!(d.choose().unwrap_err().contains("folder"));
        d.set_file_name(" z.json ");
        assert_eq!(d.choose().unwrap(), absolute(t.path()).join("z.json"));
    }

    #[test]
    fn save_names_are_validated_and_get_an_extension() {
        let ext = vec!["png".to_string()];
        assert_eq!(validate_save_name("shot", &ext).unwrap(), "shot.png");
        assert_eq!(validate_save_name("shot.PNG", &ext).unwrap(), "shot.PNG");
        assert_eq!(validate_save_name("shot.json", &ext).unwrap(), "shot.json.png");
        assert_eq!(validate_save_name("any.thing", &[]).unwrap(), "any.thing");
        for bad in ["", "  ", ".", "..", "a/b.png", "a\\b.png", "nul\0.png"] {
            assert!(validate_save_name(bad, &ext).is_err(), "{bad:?}");
        }
        let t = tree();
        let root = absolute(t.path());
        let mut d = FileDialog::new(Mode::Save, t.path(), &["json"]);
        d.set_file_name("new_tf");
        assert_eq!(d.choose().unwrap(), root.join("new_tf.json"));
        d.set_file_name("z.json");
        assert_eq!(d.choose().unwrap(), root.join("z.json"), "overwriting is allowed (the window warns)");
        std::fs::create_dir(root.join("dir.json")).unwrap();
        d.set_file_name("dir.json");
        assert!(d.choose().unwrap_err().contains("folder"));
        let abs = root.join("b_dir/abs.json");
        d.set_file_name(abs.to_str().unwrap());
        assert_eq!(d.choose().unwrap(), abs);
        d.set_file_name(root.join("missing/x.json").to_str().unwrap());
        assert!(d.choose().unwrap_err().contains("no folder"));
    }

    #[test]
    fn for_field_starts_in_the_fields_folder() {
        let t = tree();
        let root = absolute(t.path());
        let field = root.join("b_dir/inner.json");
        let d = FileDialog::for_field(Mode::Open, field.to_str().unwrap(), &["json"]);
        assert_eq!((d.dir(), d.file_name()), (root.join("b_dir").as_path(), "inner.json"));
        let d = FileDialog::for_field(Mode::Open, root.to_str().unwrap(), &["json"]);
        assert_eq!((d.dir(), d.file_name()), (root.as_path(), ""));
        let d = FileDialog::for_field(Mode::Save, "tf.json", &["json"]);
        assert_eq!((d.dir(), d.file_name()), (absolute(Path::new(".")).as_path(), "tf.json"));
    }
}

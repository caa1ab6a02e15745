//! The Markdown pages (README, docs/, the examples' pages): every code fence is closed,
//! and every relative link reaches a file of the repository and, with `#anchor`, a
//! heading of that file.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `.md` file of the repository outside build output and hidden folders.
fn pages() -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name().to_string_lossy().to_string();
            if name.starts_with('.') || name == "target" || name == "node_modules" {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else if name.ends_with(".md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The fence that opens a code block on this line (its character and length), if any.
fn fence(line: &str) -> Option<(char, usize)> {
    let t = line.trim_start();
    if line.len() - t.len() > 3 {
        return None;
    }
    let c = t.chars().next()?;
    if c != '`' && c != '~' {
        return None;
    }
    let n = t.chars().take_while(|&x| x == c).count();
    (n >= 3).then_some((c, n))
}

/// The lines outside code blocks, with their numbers; `Err` names an unclosed fence.
fn prose(text: &str) -> Result<Vec<(usize, &str)>, usize> {
    let mut out = Vec::new();
    let mut open: Option<(char, usize, usize)> = None;
    for (i, line) in text.lines().enumerate() {
        match (open, fence(line)) {
            (None, Some((c, n))) => open = Some((c, n, i + 1)),
            // a fence closes on the same character, at least as long, with nothing after
            (Some((c, n, _)), Some((c2, n2)))
                if c == c2 && n2 >= n && line.trim().chars().all(|x| x == c) =>
            {
                open = None
            }
            (None, None) => out.push((i + 1, line)),
            _ => {}
        }
    }
    match open {
        Some((_, _, at)) => Err(at),
        None => Ok(out),
    }
}

/// GitHub's anchor of a heading: lower case, punctuation dropped but `-` and `_`, spaces
/// to `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == '-' || *c == '_' || *c == ' ')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of a page's headings (repeats numbered as GitHub does).
fn anchors(text: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    let Ok(lines) = prose(text) else {
        return seen;
    };
    for (_, line) in lines {
        let t = line.trim_start();
        if !t.starts_with('#') {
            continue;
        }
        let heading = t.trim_start_matches('#');
        if !heading.starts_with(' ') {
            continue;
        }
        let base = slug(heading);
        let mut name = base.clone();
        let mut k = 1;
        while seen.contains(&name) {
            name = format!("{base}-{k}");
            k += 1;
        }
        seen.insert(name);
    }
    seen
}

/// The targets of the inline links `[text](target)` of a line (images too), without
/// inline code spans.
fn links(line: &str) -> Vec<String> {
    // drop `code` spans: a link inside one is no link
    let mut plain = String::new();
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
        } else if !in_code {
            plain.push(c);
        }
    }
    let mut out = Vec::new();
    let mut rest = plain.as_str();
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let Some(end) = after.find(')') else { break };
        let target = after[..end].split_whitespace().next().unwrap_or("");
        out.push(target.to_string());
        rest = &after[end..];
    }
    out
}

fn is_external(target: &str) -> bool {
    target.contains("://") || target.starts_with("mailto:")
}

/// The problems of one page: unclosed fences, links to files that do not exist, anchors
/// no heading has.
fn problems(page: &Path) -> Vec<String> {
    let name = page
        .strip_prefix(root())
        .unwrap_or(page)
        .display()
        .to_string();
    let Ok(text) = std::fs::read_to_string(page) else {
        return vec![format!("{name}: unreadable")];
    };
    let lines = match prose(&text) {
        Ok(l) => l,
        Err(at) => return vec![format!("{name}:{at}: code fence never closed")],
    };
    let mut out = Vec::new();
    for (n, line) in lines {
        for target in links(line) {
            if target.is_empty() || is_external(&target) {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let dest = if file.is_empty() {
                page.to_path_buf()
            } else {
                page.parent().unwrap_or(Path::new(".")).join(file)
            };
            if !dest.exists() {
                out.push(format!("{name}:{n}: link to {target}: no such file"));
                continue;
            }
            if let Some(a) = anchor {
                if dest.extension().is_some_and(|e| e == "md") {
                    let there = std::fs::read_to_string(&dest).unwrap_or_default();
                    if !anchors(&there).contains(a) {
                        out.push(format!("{name}:{n}: link to {target}: no such heading"));
                    }
                }
            }
        }
    }
    out
}

#[test]
fn every_page_closes_its_fences_and_every_relative_link_resolves() {
    let pages = pages();
    assert!(
        pages.len() >= 10 && pages.iter().any(|p| p.ends_with("README.md")),
        "found {} pages",
        pages.len()
    );
    let all: Vec<String> = pages.iter().flat_map(|p| problems(p)).collect();
    assert!(all.is_empty(), "{}", all.join("\n"));
}

#[test]
fn the_checker_finds_an_unclosed_fence_a_missing_file_and_a_missing_heading() {
    let dir = std::env::temp_dir().join(format!("superhelix-docs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let page = dir.join("page.md");
    std::fs::write(&page, "# Title\n\n```toml\nx = 1\n").expect("write");
    assert!(problems(&page)[0].contains("code fence never closed"));
    std::fs::write(
        &page,
        "# Title\n\n## Two words\n\n[a](other.md) [b](#two-words) [c](#nowhere) `[d](nope.md)`\n",
    )
    .expect("write");
    let found = problems(&page);
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(found[0].contains("other.md: no such file"), "{found:?}");
    assert!(found[1].contains("#nowhere: no such heading"), "{found:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The scene of the README's "Your first scene" is valid and does what the README says
/// of it, over its whole run (head coordinates): the curly strand's coil hangs below its
/// root (its whole centreline below the root, its lowest point more than 3 cm down, the
/// length of its coil's axis at rest, and within 3 cm of the root's vertical: held out
/// sideways, its coil reached 7 cm across; measured 5.6 cm down and 1.8 cm across), and
/// the smooth strand swings onto the ball (a sample touching it at some step's end,
/// pressing on it: measured 1.4·10⁻⁵ N, about half the strand's weight).
#[test]
fn the_readme_first_scene_does_what_the_readme_says() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let at = readme.find("## Your first scene").expect("section");
    let start = readme[at..].find("```toml").expect("a toml block") + at + "```toml".len();
    let end = readme[start..].find("```").expect("closed") + start;
    let setup = superhelix::runtime::parse_scene(&readme[start..end]).expect("valid");
    let steps = (setup.config.duration / setup.config.dt).round() as usize;
    let mut sim = superhelix::runtime::Simulation::new(setup, None).expect("builds");
    let (curly, smooth) = (0, 1);
    let length = sim.strand(curly).geometry.length();
    let root = sim.position_at(curly, 0.0);
    let (mut touched, mut pressed) = (0, 0.0f64);
    let (mut highest, mut lowest, mut widest) = (f64::NEG_INFINITY, 0.0f64, 0.0f64);
    for _ in 0..=steps {
        for k in 1..=100 {
            let p = sim.position_at(curly, length * k as f64 / 100.0) - root;
            highest = highest.max(p.z);
            lowest = lowest.min(p.z);
            widest = widest.max(p.x.hypot(p.y));
        }
        let contact = sim.contact_summary(smooth).expect("contacts");
        touched = touched.max(contact.body_contacts);
        pressed = pressed.max(contact.normal_force);
        if sim.time() < sim.config().duration - 1e-9 {
            sim.step().expect("step");
        }
    }
    eprintln!(
        "curly: highest {highest:.4} m, lowest {lowest:.4} m, widest {widest:.4} m from its root; smooth: at most {touched} samples on the ball, {pressed:.2e} N"
    );
    assert!(
        highest < 0.0 && lowest < -0.03 && widest < 0.03,
        "the curl does not hang"
    );
    assert!(
        touched > 0 && pressed > 0.0,
        "the smooth strand missed the ball"
    );
}

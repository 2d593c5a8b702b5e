//! The bearer token that mutating endpoints require: given (flag, config or
//! TRAFFICMESH_ADMIN_TOKEN), else read from the token file, else generated at
//! first start, written to that file (mode 0600) and printed once to stdout.
//! It is never logged.

use std::io::{Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

use anyhow::{Context, Result, bail};

/// Where the token came from; `Generated` is the only case that prints it.
#[derive(Debug, PartialEq)]
pub enum Source {
    Given,
    File,
    Generated,
}

pub fn resolve(given: Option<String>, file: &Path) -> Result<(String, Source)> {
    if let Some(token) = given {
        check(&token).context("the admin token (--token / TRAFFICMESH_ADMIN_TOKEN)")?;
        return Ok((token, Source::Given));
    }
    match std::fs::read_to_string(file) {
        Ok(text) => {
            let token = text.trim().to_string();
            check(&token).with_context(|| format!("the admin token in {}", file.display()))?;
            Ok((token, Source::File))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let token = generate()?;
            write_new(file, &token)?;
            Ok((token, Source::Generated))
        }
        Err(e) => {
            Err(e).with_context(|| format!("cannot read the admin token file {}", file.display()))
        }
    }
}

fn check(token: &str) -> Result<()> {
    if token.len() < 16 {
        bail!("is shorter than 16 characters");
    }
    if !token.chars().all(|c| c.is_ascii_graphic()) {
        bail!("must be printable ASCII without spaces");
    }
    Ok(())
}

/// 32 random bytes from the kernel, hex.
fn generate() -> Result<String> {
    let mut bytes = [0u8; 32];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("cannot read /dev/urandom to generate the admin token")?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Creates the file readable by its owner only; never replaces an existing one.
fn write_new(file: &Path, token: &str) -> Result<()> {
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(file)
        .with_context(|| format!("cannot create the admin token file {}", file.display()))?;
    f.write_all(format!("{token}\n").as_bytes())
        .and_then(|_| f.sync_all())
        .with_context(|| format!("cannot write {}", file.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_once_then_read_back() {
        let dir = std::env::temp_dir().join(format!("tm-token-{}", std::process::id()));
        let file = dir.join("sub/admin.token");
        let (t1, s1) = resolve(None, &file).unwrap();
        assert_eq!(s1, Source::Generated);
        assert_eq!(t1.len(), 64);
        let mode = std::fs::metadata(&file).unwrap().permissions();
        assert_eq!(
            std::os::unix::fs::PermissionsExt::mode(&mode) & 0o777,
            0o600
        );
        let (t2, s2) = resolve(None, &file).unwrap();
        assert_eq!((t2, s2), (t1, Source::File));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_short_given_token_is_refused() {
        let err = resolve(Some("abc".into()), Path::new("/nonexistent")).unwrap_err();
        assert!(format!("{err:#}").contains("shorter than 16"), "{err:#}");
    }
}

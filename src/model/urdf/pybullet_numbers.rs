//! Lists of numbers that a strict reader refuses and PyBullet reads with an
//! evident meaning. PyBullet's `parseVector3` splits the text at spaces, reads
//! each word with `atof` (its leading number, 0 if none) and takes the first
//! three; Pinocchio's urdfdom and MuJoCo's importer refuse such text. We accept
//! only the forms where PyBullet's reading is what the file means, and the
//! caller warns about each; anything else stays an error, since `atof` turns
//! garbage into zeros silently.

/// `text` as `K` numbers, and how it was read, where it is one of:
/// - numbers followed by a stray comma or full stop (`0.07, 0, -0.69`,
///   `-1.57.`), which `atof` reads as the numbers;
/// - more than three numbers for a 3-vector (`0 1.57 0 0`): the first three,
///   as PyBullet takes them;
/// - an unexpanded xacro `$(optenv NAME default)`: the default, the value
///   xacro gives it with NAME unset (PyBullet reads the words of the
///   expression with `atof` instead, which no one means).
///
/// `None` for anything else.
pub(super) fn read<const K: usize>(text: &str) -> Option<([f64; K], String)> {
    if let Some((name, default)) = optenv(text) {
        let v = strict(default)?;
        return Some((
            v,
            format!(
                "an unexpanded xacro expression, read as its default '{default}' \
                 (xacro's value with {name} unset)"
            ),
        ));
    }
    let words: Vec<&str> = text.split_whitespace().collect();
    let strays = words
        .iter()
        .any(|w| finite(w).is_none() && stray(w).is_some());
    let numbers: Vec<f64> = words
        .iter()
        .map(|w| finite(w).or_else(|| stray(w)))
        .collect::<Option<_>>()?;
    let extra = numbers.len() > K;
    if extra && K != 3 {
        return None;
    }
    let how = match (strays, extra) {
        (true, false) => "a stray ',' or '.' after a number, ignored as atof ignores it",
        (false, true) => "more than three numbers: the first three, as PyBullet takes them",
        (true, true) => {
            "a stray ',' or '.' after a number, and more than three numbers: the first \
             three, as PyBullet reads them"
        }
        (false, false) => return None,
    };
    Some((numbers.get(..K)?.try_into().ok()?, how.to_string()))
}

/// Exactly `K` whitespace-separated finite numbers.
pub(super) fn strict<const K: usize>(text: &str) -> Option<[f64; K]> {
    super::xml::numbers(text).and_then(|v| v.try_into().ok())
}

/// The variable name and the default of `$(optenv NAME default)`.
fn optenv(text: &str) -> Option<(&str, &str)> {
    let inner = text.trim().strip_prefix("$(optenv")?.strip_suffix(')')?;
    let inner = inner.trim_start();
    let (name, default) = inner.split_once(char::is_whitespace)?;
    Some((name, default.trim()))
}

/// The number before a stray ',' or '.' ending `word`.
fn stray(word: &str) -> Option<f64> {
    finite(word.strip_suffix([',', '.'])?)
}

fn finite(word: &str) -> Option<f64> {
    word.parse::<f64>().ok().filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commas_extra_numbers_and_optenv_are_read_as_meant() {
        let (v, how) = read::<3>("0.07, 0, -0.69").unwrap();
        assert_eq!((v, how.contains("stray")), ([0.07, 0.0, -0.69], true));
        let (v, how) = read::<3>("0 1.25 0 0").unwrap();
        assert_eq!((v, how.contains("first three")), ([0.0, 1.25, 0.0], true));
        let (v, how) = read::<3>("$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)").unwrap();
        assert_eq!(v, [0.19, 0.0, 0.149]);
        assert!(how.contains("HUSKY_IMU_XYZ"), "{how}");
        assert_eq!(read::<1>("2.5,").unwrap().0, [2.5]);
        assert_eq!(read::<1>("-1.57.").unwrap().0, [-1.57]);
    }

    #[test]
    fn garbage_and_plain_text_are_not_read() {
        for text in [
            "a b c",
            "1 2",
            "1,2,3",
            "1 2 x",
            "1 2 3",
            "1 2 3 y",
            "1 nan 3,",
            "1 2 3,,",
            "1 2 .",
            ",",
            "1 2 3;",
            "$(optenv X 1 2)",
            "$(env X)",
            "",
        ] {
            assert!(read::<3>(text).is_none(), "{text}");
        }
        // Extra numbers are PyBullet's reading of a 3-vector only.
        assert!(read::<1>("1 2").is_none());
        assert!(read::<2>("1 2 3").is_none());
    }
}

//! The limits of what hamel reads: each is a clear error at the place it is exceeded, so that
//! no input exhausts the machine (a 1 MB expression, `x^1000000000`, ten thousand nested
//! parentheses). They are far above what a mechanical model needs: the expanded Whipple
//! bicycle's longest expression is 20 kB, nested 5 deep, with exponents of at most 4.

/// Bytes of one expression's text.
pub const MAX_BYTES: usize = 256 * 1024;

/// Depth of an expression's tree: calls, unary minus, powers and chains of divisions each add
/// a level.
pub const MAX_DEPTH: usize = 100;

/// Depth of the parser's descent through the text: every operand adds a level, and so does
/// every pair of parentheses. It is larger than [`MAX_DEPTH`] so that whatever hamel prints
/// of a tree within [`MAX_DEPTH`] (which parenthesises, say, a negative exponent:
/// `x^-y^-z` is printed `x^(-y^(-z))`) reads back; the fuzzer found 100 levels too few.
pub const MAX_NESTING: usize = 4 * MAX_DEPTH;

/// Size of a constant exponent (its numerator and denominator).
pub const MAX_EXPONENT: u32 = 100;

/// Digits of a number literal.
pub const MAX_DIGITS: usize = 100;

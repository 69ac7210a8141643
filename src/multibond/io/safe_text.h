#pragma once
/// \file
/// Text from a model file or a results folder (names, units, run.json values, a program's log),
/// made safe for the interpreter it goes to: one function per interpreter, each taking any bytes.
/// Bytes that are not UTF-8 become U+FFFD (shown as a replacement mark), and control characters
/// (C0, DEL, C1) never pass through, so no text can end a line, a string or a statement early.

#include <string>
#include <string_view>

namespace multibond {

/// `s` with every byte sequence that is not UTF-8 (overlong forms, surrogates included) replaced
/// by U+FFFD; control characters other than line feed and tab also become U+FFFD.
std::string ValidUtf8(std::string_view s);

/// Text for an HTML page, in an element or in a (double- or single-quoted) attribute value:
/// & < > " ' as character references, ValidUtf8 otherwise.
std::string HtmlEscape(std::string_view s);

/// A gnuplot string literal in single quotes: gnuplot substitutes neither `backquotes` nor
/// @macros there, and ' is written ''. Line breaks and other control characters become spaces
/// (a string cannot span lines), and a backquote becomes U+FFFD all the same. The text is still
/// enhanced text when the terminal is `enhanced`; file text shown as it is goes through
/// GnuplotLiteralText first.
std::string GnuplotString(std::string_view s);

/// File text to be shown as it is inside an enhanced-text gnuplot label: each of ^ _ { } & ~ @
/// and the backslash gets a backslash, so that the text cannot change fonts or sizes. The result goes into
/// GnuplotString (single quotes keep the backslashes as they are).
std::string GnuplotLiteralText(std::string_view s);

/// Text for the rest of a gnuplot comment line (after '#'): one line, no backquote, not ending in
/// a backslash (which would join the next line to the comment).
std::string GnuplotComment(std::string_view s);

/// A double-quoted Graphviz DOT string (an ID, a label, a tooltip): " and \ escaped, a line
/// break as \n, a carriage return dropped, other control characters as U+FFFD.
std::string DotString(std::string_view s);

/// Text inside a DOT HTML-like label (<...>): & < > " ' as character references, a line break as
/// <BR/>, control characters as U+FFFD.
std::string DotHtmlText(std::string_view s);

/// Text for a message on a terminal (an error, a warning): control characters other than line
/// feed and tab, and bytes that are not UTF-8, written as \xNN, so that no escape sequence reaches
/// the terminal and the bytes stay visible.
std::string MessageText(std::string_view s);

}  // namespace multibond

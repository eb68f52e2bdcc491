#include "report_page.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace lab::report {

namespace fs = std::filesystem;

namespace {

std::string readBinary(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(in[i]) << 16) | (static_cast<unsigned char>(in[i + 1]) << 8) |
                       static_cast<unsigned char>(in[i + 2]);
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63], out += k[(v >> 6) & 63], out += k[v & 63];
  }
  if (i < in.size()) {
    unsigned v = static_cast<unsigned char>(in[i]) << 16;
    if (i + 1 < in.size()) v |= static_cast<unsigned char>(in[i + 1]) << 8;
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string htmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Inline Markdown (`code`, **bold**) as HTML.
std::string inlineHtml(const std::string& md) {
  const std::string s = htmlEscape(md);
  std::string out;
  bool code = false, bold = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '`') {
      out += code ? "</code>" : "<code>";
      code = !code;
    } else if (!code && s.compare(i, 2, "**") == 0) {
      out += bold ? "</b>" : "<b>";
      bold = !bold;
      ++i;
    } else {
      out += s[i];
    }
  }
  if (code) out += "</code>";
  if (bold) out += "</b>";
  return out;
}

}  // namespace

void writeText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + p.string() + "; check the directory is writable");
  out << text;
}

std::string toMarkdown(const std::vector<Block>& blocks) {
  std::string md;
  for (const auto& b : blocks) {
    switch (b.kind) {
      case Block::Kind::kH1: md += "# " + b.text + "\n\n"; break;
      case Block::Kind::kH2: md += "## " + b.text + "\n\n"; break;
      case Block::Kind::kPara: md += b.text + "\n\n"; break;
      case Block::Kind::kList:
        for (const auto& it : b.items) md += "- " + it + "\n";
        md += "\n";
        break;
      case Block::Kind::kTable:
        for (std::size_t r = 0; r < b.rows.size(); ++r) {
          md += "|";
          for (const auto& c : b.rows[r]) md += " " + c + " |";
          md += "\n";
          if (r == 0) {
            md += "|";
            for (std::size_t c = 0; c < b.rows[0].size(); ++c) md += "---|";
            md += "\n";
          }
        }
        md += "\n";
        break;
      case Block::Kind::kImage: md += "![" + b.text + "](" + b.image + ")\n\n"; break;
    }
  }
  return md;
}

std::string toHtml(const std::vector<Block>& blocks, const fs::path& dir, bool images) {
  std::string h =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Model lab report</title>\n"
      "<style>body{font-family:sans-serif;max-width:960px;margin:2em auto;line-height:1.4}"
      "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:left}"
      "code{background:#f3f3f3;padding:0 3px}img{max-width:100%}</style></head><body>\n";
  for (const auto& b : blocks) {
    switch (b.kind) {
      case Block::Kind::kH1: h += "<h1>" + inlineHtml(b.text) + "</h1>\n"; break;
      case Block::Kind::kH2: h += "<h2>" + inlineHtml(b.text) + "</h2>\n"; break;
      case Block::Kind::kPara: h += "<p>" + inlineHtml(b.text) + "</p>\n"; break;
      case Block::Kind::kList:
        h += "<ul>\n";
        for (const auto& it : b.items) h += "<li>" + inlineHtml(it) + "</li>\n";
        h += "</ul>\n";
        break;
      case Block::Kind::kTable:
        h += "<table>\n";
        for (std::size_t r = 0; r < b.rows.size(); ++r) {
          h += "<tr>";
          for (const auto& c : b.rows[r]) h += (r ? "<td>" : "<th>") + inlineHtml(c) + (r ? "</td>" : "</th>");
          h += "</tr>\n";
        }
        h += "</table>\n";
        break;
      case Block::Kind::kImage:
        if (images && fs::exists(dir / b.image))
          h += "<p><img alt=\"" + htmlEscape(b.text) + "\" src=\"data:image/png;base64," +
               base64(readBinary(dir / b.image)) + "\"></p>\n";
        else
          h += "<p>(plot " + htmlEscape(b.image) + " not drawn: gnuplot is missing or failed)</p>\n";
        break;
    }
  }
  return h + "</body></html>\n";
}

}  // namespace lab::report

#include "multipart_form.h"

#include <algorithm>
#include <cctype>
#include <optional>

namespace server::http {
namespace {

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

/// The value of `key=` in a header's parameters ("form-data; name="yaml"; filename="m.yaml""), unquoted.
std::optional<std::string> Parameter(const std::string& header, const std::string& key) {
  const std::string lower = Lower(header);
  for (std::size_t at = lower.find(key + "="); at != std::string::npos; at = lower.find(key + "=", at + 1)) {
    if (at > 0 && lower[at - 1] != ';' && lower[at - 1] != ' ' && lower[at - 1] != '\t')
      continue;  // "filename=" ≠ "name="
    std::size_t start = at + key.size() + 1;
    if (start < header.size() && header[start] == '"') {
      const std::size_t end = header.find('"', start + 1);
      if (end == std::string::npos) return std::nullopt;
      return header.substr(start + 1, end - start - 1);
    }
    const std::size_t end = header.find(';', start);
    std::string value = header.substr(start, end == std::string::npos ? std::string::npos : end - start);
    while (!value.empty() && std::isspace(static_cast<unsigned char>(value.back()))) value.pop_back();
    return value;
  }
  return std::nullopt;
}

}  // namespace

storage::Result<std::vector<FormPart>> ParseMultipartForm(const std::string& content_type,
                                                          const std::string& body, std::size_t max_parts) {
  if (Lower(content_type).rfind("multipart/form-data", 0) != 0) {
    return storage::InvalidArgument("Content-Type: expected multipart/form-data");
  }
  const auto boundary = Parameter(content_type, "boundary");
  if (!boundary || boundary->empty() || boundary->size() > 70) {
    return storage::InvalidArgument("Content-Type: multipart/form-data needs a boundary of 1–70 characters");
  }
  const std::string delimiter = "--" + *boundary;
  std::size_t at = body.find(delimiter);
  if (at == std::string::npos) return storage::InvalidArgument("multipart: the body has no boundary line");
  std::vector<FormPart> parts;
  while (true) {
    at += delimiter.size();
    if (body.compare(at, 2, "--") == 0) return parts;  // the closing delimiter
    if (body.compare(at, 2, "\r\n") != 0)
      return storage::InvalidArgument("multipart: a boundary line does not end in CRLF");
    at += 2;
    if (parts.size() == max_parts) {
      return storage::InvalidArgument("multipart: more than " + std::to_string(max_parts) + " parts");
    }
    const std::string which = "multipart: part " + std::to_string(parts.size() + 1);
    const std::size_t headers_end = body.find("\r\n\r\n", at);
    if (headers_end == std::string::npos || headers_end - at > 8192) {
      return storage::InvalidArgument(which + ": headers missing, unterminated or over 8 KiB");
    }
    FormPart part;
    bool disposition = false;
    for (std::size_t line = at; line < headers_end;) {
      const std::size_t end = std::min(body.find("\r\n", line), headers_end);
      const std::string header = body.substr(line, end - line);
      line = end + 2;
      if (Lower(header).rfind("content-disposition:", 0) != 0) continue;
      disposition = true;
      part.name = Parameter(header, "name").value_or("");
      part.filename = Parameter(header, "filename").value_or("");
    }
    if (!disposition || part.name.empty())
      return storage::InvalidArgument(which + " has no Content-Disposition name");
    if (part.name.size() > 255 || part.filename.size() > 255) {
      return storage::InvalidArgument(which + ": name or filename longer than 255 bytes");
    }
    const auto control = [](unsigned char c) { return c < 0x20 || c == 0x7f; };
    if (std::any_of(part.name.begin(), part.name.end(), control) ||
        std::any_of(part.filename.begin(), part.filename.end(), control)) {
      return storage::InvalidArgument(which + ": name or filename holds a control character");
    }
    const std::size_t content = headers_end + 4;
    const std::size_t next = body.find("\r\n" + delimiter, content);
    if (next == std::string::npos)
      return storage::InvalidArgument(which + " (" + part.name + ") is not closed by a boundary");
    part.body = body.substr(content, next - content);
    parts.push_back(std::move(part));
    at = next + 2;
  }
}

}  // namespace server::http

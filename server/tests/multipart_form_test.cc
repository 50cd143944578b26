// multipart/form-data as the dashboard's map_server upload sends it: parts with names and file names, binary
// bodies kept byte for byte, and every malformed or oversized form refused naming what is wrong.
#include "multipart_form.h"

#include <gtest/gtest.h>

#include "status_matchers.h"

namespace server::http {
namespace {

const std::string kType = "multipart/form-data; boundary=----fleetd42";

std::string Part(const std::string& name, const std::string& filename, const std::string& body) {
  return "------fleetd42\r\nContent-Disposition: form-data; name=\"" + name + "\"" +
         (filename.empty() ? "" : "; filename=\"" + filename + "\"") +
         "\r\nContent-Type: application/octet-stream\r\n\r\n" + body + "\r\n";
}

TEST(MultipartForm, ReadsNamedPartsWithBinaryBodies) {
  const std::string pgm = std::string("P5\n2 1\n255\n\xfe\x00", 13);
  const auto parts = ParseMultipartForm(kType, Part("yaml", "map.yaml", "image: map.pgm\n") +
                                                   Part("image", "map.pgm", pgm) + "------fleetd42--\r\n");
  ASSERT_THAT(parts, IsOk());
  ASSERT_EQ(parts->size(), 2u);
  EXPECT_EQ((*parts)[0].name, "yaml");
  EXPECT_EQ((*parts)[0].filename, "map.yaml");
  EXPECT_EQ((*parts)[0].body, "image: map.pgm\n");
  EXPECT_EQ((*parts)[1].filename, "map.pgm");
  EXPECT_EQ((*parts)[1].body, pgm);
  // A quoted boundary, as some clients write it.
  EXPECT_THAT(ParseMultipartForm("multipart/form-data; boundary=\"----fleetd42\"", "------fleetd42--\r\n"),
              IsOk());
}

TEST(MultipartForm, RefusesMalformedAndOversizedFormsNamingWhy) {
  const auto refused = [](const std::string& type, const std::string& body, const std::string& why) {
    const auto parts = ParseMultipartForm(type, body, 3);
    ASSERT_FALSE(parts.ok()) << why;
    EXPECT_THAT(parts, StatusIs(storage::StatusCode::kInvalidArgument));
    EXPECT_NE(parts.status().message().find(why), std::string::npos) << parts.status().ToString();
  };
  const std::string closed = "------fleetd42--\r\n";
  refused("application/json", closed, "expected multipart/form-data");
  refused("multipart/form-data", closed, "needs a boundary");
  refused("multipart/form-data; boundary=" + std::string(71, 'b'), closed, "needs a boundary of 1–70");
  refused(kType, "no boundary here", "no boundary line");
  refused(kType, Part("a", "", "1") + Part("b", "", "2") + Part("c", "", "3") + Part("d", "", "4") + closed,
          "more than 3 parts");
  refused(kType, "------fleetd42\r\nContent-Type: text/plain\r\n\r\nx\r\n" + closed,
          "part 1 has no Content-Disposition name");
  refused(kType, "------fleetd42\r\nContent-Disposition: form-data; name=\"yaml\"\r\n\r\nnever closed",
          "is not closed by a boundary");
  refused(kType, "------fleetd42\r\n" + std::string(9000, 'h'),
          "headers missing, unterminated or over 8 KiB");
  refused(kType, Part("image", "map\x01.pgm", "x") + closed, "control character");
  refused(kType, Part(std::string(300, 'n'), "", "x") + closed, "longer than 255 bytes");
  refused(kType, "------fleetd42garbage", "does not end in CRLF");
}

}  // namespace
}  // namespace server::http

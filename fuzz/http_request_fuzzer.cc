// libFuzzer harness: fleetd's HTTP request parsing (Boost.Beast's request_parser with fleetd's body limit)
// on arbitrary bytes, then the fields fleetd reads from a parsed request.
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace http = boost::beast::http;
  http::request_parser<http::string_body> parser;
  parser.body_limit(1 << 20);
  parser.eager(true);
  boost::beast::error_code ec;
  parser.put(boost::asio::buffer(data, size), ec);
  if (ec || !parser.is_done()) return 0;
  const auto& message = parser.get();
  std::string target(message.target());
  (void)target.find('?');
  for (const auto& field : message) (void)std::string(field.name_string()).size();
  (void)message.keep_alive();
  return 0;
}

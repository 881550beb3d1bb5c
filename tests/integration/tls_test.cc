// semmapd over TLS and mutual TLS: who gets served and who is refused. The keys and
// certificates are made here by the openssl command-line tool (never committed); without it
// the tests skip.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>

#include "client/lib/map_client.h"
#include "server/semmap_server.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

// A test CA signing a server certificate for 127.0.0.1 and a client certificate, and a second
// CA (not trusted by anyone) signing a client certificate of its own. Made once per process.
struct TestKeys {
  testing::TempDir dir;
  bool made = false;

  TestKeys() {
    const std::string d = dir.path();
    const std::string key = "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    std::ofstream(d + "/server.ext") << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
    const std::string script =
        "cd " + d + " && " + "openssl req -x509 " + key +
        " -keyout ca.key -out ca.pem -days 2 -subj /CN=test-ca && " + "openssl req -x509 " + key +
        " -keyout other.key -out other.pem -days 2 -subj /CN=other &&" + " openssl req " + key +
        " -keyout server.key -out server.csr -subj /CN=localhost && " +
        "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 2 " +
        "-extfile server.ext -out server.pem && " + "openssl req " + key +
        " -keyout client.key -out client.csr -subj /CN=client && " +
        "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 2 " +
        "-out client.pem && " + "openssl req " + key +
        " -keyout stranger.key -out stranger.csr -subj /CN=stranger && " +
        "openssl x509 -req -in stranger.csr -CA other.pem -CAkey other.key -CAcreateserial " +
        "-days 2 -out stranger.pem";
    made = std::system(("(" + script + ") >/dev/null 2>&1").c_str()) == 0;
  }
};

const TestKeys& Keys() {
  static const TestKeys keys;
  return keys;
}

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!Keys().made) GTEST_SKIP() << "openssl could not make test certificates (is it installed?)";
  }

  static std::string Key(const std::string& name) { return Keys().dir.File(name); }

  // semmapd on an ephemeral port with the given TLS files.
  StatusOr<std::unique_ptr<SemmapServer>> Serve(const std::string& client_ca = "") {
    ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = data_.path();
    options.tls_cert_file = Key("server.pem");
    options.tls_key_file = Key("server.key");
    options.tls_client_ca_file = client_ca;
    return SemmapServer::Start(options);
  }

  // What ListMaps answers a client of `server` with these TLS files (none: plaintext).
  static StatusCode ListMapsAs(const SemmapServer& server, bool tls, const std::string& ca,
                               const std::string& cert = "", const std::string& key = "") {
    ClientOptions options;
    options.server = server.address();
    options.query_timeout = std::chrono::seconds(10);
    if (tls) {
      StatusOr<ClientTls> files =
          LoadClientTls(ca, cert.empty() ? "" : Key(cert), key.empty() ? "" : Key(key));
      EXPECT_TRUE(files.ok()) << files.status().ToString();
      options.tls = *files;
    }
    MapClient client(options);
    return client.ListMaps().status().code();
  }

  testing::TempDir data_;
};

TEST_F(TlsTest, ServerTlsServesClientsThatTrustItsCaOnly) {
  auto server = Serve();
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  EXPECT_EQ(ListMapsAs(**server, true, Key("ca.pem")), StatusCode::kOk);
  EXPECT_EQ(ListMapsAs(**server, false, ""), StatusCode::kUnavailable);  // plaintext
  EXPECT_EQ(ListMapsAs(**server, true, Key("other.pem")), StatusCode::kUnavailable);
}

TEST_F(TlsTest, MutualTlsServesClientsWithACertificateFromItsClientCa) {
  auto server = Serve(Key("ca.pem"));
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  EXPECT_EQ(ListMapsAs(**server, true, Key("ca.pem"), "client.pem", "client.key"), StatusCode::kOk);
  EXPECT_EQ(ListMapsAs(**server, true, Key("ca.pem")), StatusCode::kUnavailable);  // no cert
  EXPECT_EQ(ListMapsAs(**server, true, Key("ca.pem"), "stranger.pem", "stranger.key"),
            StatusCode::kUnavailable);
  EXPECT_EQ(ListMapsAs(**server, false, ""), StatusCode::kUnavailable);
}

TEST_F(TlsTest, BadTlsOptionsFailTheStartNamingTheFlag) {
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = data_.path();
  options.tls_cert_file = Key("server.pem");
  Status s = SemmapServer::Start(options).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("--tls-key"), std::string::npos) << s.ToString();

  options.tls_key_file = Key("missing.key");
  s = SemmapServer::Start(options).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("--tls-key " + Key("missing.key")), std::string::npos) << s.ToString();

  options.tls_key_file = Key("server.ext");  // a file, but no PEM in it
  s = SemmapServer::Start(options).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("no PEM block"), std::string::npos) << s.ToString();

  options.tls_cert_file.clear();
  options.tls_key_file.clear();
  options.tls_client_ca_file = Key("ca.pem");
  EXPECT_EQ(SemmapServer::Start(options).status().code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(LoadClientTls("", Key("client.pem"), "").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(LoadClientTls(Key("nope.pem"), "", "").status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap

#pragma once
// Debian's chromium, headless, driven through its DevTools protocol over
// --remote-debugging-pipe (fd 3: commands in, fd 4: answers and events out,
// each a JSON text ended by a NUL byte): no port, no extra package.
#include <fcntl.h>
#include <openssl/evp.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace mrsns::test {

class HeadlessChromium {
 public:
  HeadlessChromium(const std::filesystem::path& program, const std::filesystem::path& profile, int width, int height) {
    int in[2];
    int out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    // Out of the way of 3 and 4, so the dup2s below never meet their own fd.
    auto high = [](int fd) {
      const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, 10);
      ::close(fd);
      return moved;
    };
    for (int* fd : {&in[0], &in[1], &out[0], &out[1]}) *fd = high(*fd);
    std::filesystem::create_directories(profile);
    log_ = profile / "chromium.log";
    std::vector<std::string> argv{program.string(),
                                  "--headless=new",
                                  "--remote-debugging-pipe",
                                  "--no-sandbox",  // tests run as root in CI
                                  "--no-first-run",
                                  "--no-default-browser-check",
                                  "--disable-gpu-sandbox",
                                  "--ignore-certificate-errors",  // the workstation's self-signed certificate
                                  "--use-angle=swiftshader",
                                  "--enable-unsafe-swiftshader",  // WebGL on the CPU (no GPU in CI)
                                  "--user-data-dir=" + profile.string(),
                                  "--window-size=" + std::to_string(width) + "," + std::to_string(height),
                                  "about:blank"};
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, in[0], 3);
    posix_spawn_file_actions_adddup2(&actions, out[1], 4);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    const int rc = posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(in[0]);
    ::close(out[1]);
    to_browser_ = in[1];
    from_browser_ = out[0];
    if (rc != 0) {
      pid_ = -1;
      throw std::runtime_error("cannot start " + program.string());
    }
  }

  ~HeadlessChromium() {
    if (pid_ > 0) {
      try {
        send("Browser.close", nlohmann::json::object(), false);
      } catch (...) {
      }
      for (int i = 0; i < 100; ++i) {
        int status = 0;
        if (::waitpid(pid_, &status, WNOHANG) == pid_) {
          pid_ = -1;
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      if (pid_ > 0) {
        ::kill(pid_, SIGKILL);
        int status = 0;
        ::waitpid(pid_, &status, 0);
      }
    }
    ::close(to_browser_);
    ::close(from_browser_);
  }
  HeadlessChromium(const HeadlessChromium&) = delete;
  HeadlessChromium& operator=(const HeadlessChromium&) = delete;

  /// A new tab at `url`; later page commands go to it.
  void open(const std::string& url) {
    const auto target = call("Target.createTarget", {{"url", url}}, false);
    const auto attached =
        call("Target.attachToTarget", {{"targetId", target.at("targetId")}, {"flatten", true}}, false);
    session_ = attached.at("sessionId").get<std::string>();
  }

  /// Runs `expression` in the page (a promise is awaited); its value.
  nlohmann::json evaluate(const std::string& expression) {
    const auto r =
        call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}, {"awaitPromise", true}});
    if (r.contains("exceptionDetails")) throw std::runtime_error("page exception: " + r["exceptionDetails"].dump());
    return r.at("result").value("value", nlohmann::json());
  }

  std::vector<std::uint8_t> screenshotPng() {
    const auto r = call("Page.captureScreenshot", {{"format", "png"}});
    const std::string base64 = r.at("data").get<std::string>();
    std::vector<std::uint8_t> png(base64.size() / 4 * 3 + 3);
    const int n = EVP_DecodeBlock(png.data(), reinterpret_cast<const unsigned char*>(base64.data()),
                                  static_cast<int>(base64.size()));
    if (n < 0) throw std::runtime_error("screenshot is not base64");
    std::size_t padding = 0;
    while (padding < 2 && base64.size() > padding && base64[base64.size() - 1 - padding] == '=') ++padding;
    png.resize(static_cast<std::size_t>(n) - padding);
    return png;
  }

  /// One command; its result. Throws on a protocol error or after `timeout`.
  nlohmann::json call(const std::string& method, const nlohmann::json& params, bool in_page = true,
                      std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    const int id = send(method, params, in_page);
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      for (std::size_t at; (at = buffer_.find('\0')) != std::string::npos;) {
        const auto message = nlohmann::json::parse(buffer_.substr(0, at));
        buffer_.erase(0, at + 1);
        if (message.value("id", -1) != id) continue;  // an event, or an answer nobody waits for
        if (message.contains("error")) throw std::runtime_error(method + ": " + message["error"].dump());
        return message.value("result", nlohmann::json::object());
      }
      pollfd fd{from_browser_, POLLIN, 0};
      if (::poll(&fd, 1, 50) > 0) {
        char chunk[65536];
        const ssize_t n = ::read(from_browser_, chunk, sizeof chunk);
        if (n <= 0) throw std::runtime_error("chromium closed its DevTools pipe (see " + log_.string() + ")");
        buffer_.append(chunk, static_cast<std::size_t>(n));
      }
    }
    throw std::runtime_error(method + ": no answer from chromium");
  }

 private:
  int send(const std::string& method, const nlohmann::json& params, bool in_page) {
    nlohmann::json command{{"id", ++next_id_}, {"method", method}, {"params", params}};
    if (in_page) command["sessionId"] = session_;
    const std::string text = command.dump() + std::string(1, '\0');
    for (std::size_t at = 0; at < text.size();) {
      const ssize_t n = ::write(to_browser_, text.data() + at, text.size() - at);
      if (n <= 0) throw std::runtime_error("cannot write to chromium's DevTools pipe");
      at += static_cast<std::size_t>(n);
    }
    return next_id_;
  }

  pid_t pid_ = -1;
  int to_browser_ = -1;
  int from_browser_ = -1;
  int next_id_ = 0;
  std::string session_;
  std::string buffer_;
  std::filesystem::path log_;
};

}  // namespace mrsns::test

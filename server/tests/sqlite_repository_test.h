// A test fixture with a real SQLite repository in a fresh temporary folder per test, removed afterwards.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "storage/repository.h"
#include "status_matchers.h"

namespace server {

class SqliteRepositoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 ("server-test-" + std::to_string(::getpid()) + "-" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(directory_);
    std::filesystem::create_directories(directory_);
    auto opened = storage::OpenRepository("sqlite:" + (directory_ / "fleet.db").string());
    ASSERT_THAT(opened, IsOk());
    repository_ = std::move(opened).value();
  }
  void TearDown() override {
    repository_.reset();
    std::filesystem::remove_all(directory_);
  }

  std::filesystem::path directory_;
  std::unique_ptr<storage::Repository> repository_;
};

}  // namespace server

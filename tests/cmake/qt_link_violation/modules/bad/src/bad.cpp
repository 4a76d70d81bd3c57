int badFunction() {
  return 1;
}
